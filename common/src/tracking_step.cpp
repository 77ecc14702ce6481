// One object's tracking step (steps in the header).

#include "mfot/tracking_step.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace mfot {

namespace {

const TrackingStepOptions& validated(const TrackingStepOptions& options) {
  options.validate();
  return options;
}

}  // namespace

void TrackingStepOptions::validate() const {
  if (!(std::isfinite(hypothesis.margin) && hypothesis.margin >= 0.f && hypothesis.margin <= 1.f)) {
    throw std::invalid_argument("TrackingStepOptions.hypothesis.margin must be in [0, 1] metres, got " +
                                std::to_string(hypothesis.margin));
  }
  occlusion.validate();
  fit.validate();
  if (!(hold_confidence_half_life >= 1.f && hold_confidence_half_life <= 100000.f)) {
    throw std::invalid_argument("TrackingStepOptions.hold_confidence_half_life must be in [1, 100000] frames, got " +
                                std::to_string(hold_confidence_half_life));
  }
  if (!(hold_occluded_share >= 0.f && hold_occluded_share <= 1.f)) {
    throw std::invalid_argument("TrackingStepOptions.hold_occluded_share must be in [0, 1], got " +
                                std::to_string(hold_occluded_share));
  }
  if (!(max_hold_frames >= 1 && max_hold_frames <= 100000)) {
    throw std::invalid_argument("TrackingStepOptions.max_hold_frames must be in [1, 100000], got " +
                                std::to_string(max_hold_frames));
  }
}

TrackingStep::TrackingStep(const TrackingStepOptions& options)
    : options_(validated(options)), occlusion_(options.occlusion), fit_(options.fit) {}

TrackingStepResult TrackingStep::track(const ColoredCloud& scene, const ObjectModel& model,
                                       const Eigen::AlignedBox3f& model_box, ParticleFilter& filter,
                                       Likelihood& likelihood) {
  TrackingStepResult result;
  const Pose last = filter.estimate();
  const bool tests_occlusion = options_.hold_occluded_share > 0.f || options_.exclude_occluders;
  if (tests_occlusion) occlusion_.set_model(model.cloud.positions, last);  // once for both questions
  if (options_.hold_occluded_share > 0.f) {
    occlusion_.set_scene(scene.positions);
    result.occluded_share = occlusion_.occluded_share();
    if (result.occluded_share < options_.hold_occluded_share) {
      held_in_row_ = 0;
    } else if (held_in_row_ >= options_.max_hold_frames) {
      result.hold_expired = true;
    } else {
      ++held_in_row_;
      hypothesis_.points.clear();
      hypothesis_.features.clear();
      hypothesis_.colors.clear();
      result.estimate = filter.hold();
      result.held = true;
      result.confidence =
          last_confidence_ * std::exp2(-static_cast<float>(held_in_row_) / options_.hold_confidence_half_life);
      return result;
    }
  }
  select_hypothesis_points(scene, model_box, last, options_.hypothesis, hypothesis_);
  if (options_.exclude_occluders && !result.hold_expired) {
    result.occluders_removed = occlusion_.remove_occluders(hypothesis_);
  }
  hypothesis_.features = compute_smr(hypothesis_.colors, options_.smr);
  result.hypothesis_points = hypothesis_.points.size();
  result.estimate = filter.step(hypothesis_, likelihood);
  result.confidence = last_confidence_ = fit_.fit(hypothesis_, model, model_box, result.estimate);
  return result;
}

}  // namespace mfot
