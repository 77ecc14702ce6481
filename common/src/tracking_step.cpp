// One object's tracking step (steps in the header).

#include "mfot/tracking_step.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "mfot/option_range.hpp"

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
  if (!(confidence_seen_through_weight >= 0.f && confidence_seen_through_weight <= 100.f)) {
    throw std::invalid_argument("TrackingStepOptions.confidence_seen_through_weight must be in [0, 100], got " +
                                std::to_string(confidence_seen_through_weight));
  }
  if (!(hold_occluded_share >= 0.f && hold_occluded_share <= 1.f)) {
    throw std::invalid_argument("TrackingStepOptions.hold_occluded_share must be in [0, 1], got " +
                                std::to_string(hold_occluded_share));
  }
  // The hold's occlusion test is what indexes the scene's rays and measures the occluded share; two settings
  // read them.
  const auto needs_occlusion_test = [&](bool used, const std::string& field, const std::string& why) {
    if (used && !(hold_occluded_share > 0.f)) {
      throw std::invalid_argument("TrackingStepOptions." + field + " needs hold_occluded_share > 0: " + why);
    }
  };
  needs_occlusion_test(confidence_seen_through_weight > 0.f, "confidence_seen_through_weight",
                       "the scene's rays are indexed there");
  if (!(exclude_claimed_radius >= 0.f && exclude_claimed_radius <= 0.1f)) {
    throw std::invalid_argument("TrackingStepOptions.exclude_claimed_radius must be in [0, 0.1] metres, got " +
                                std::to_string(exclude_claimed_radius));
  }
  isolated_motion.validate("TrackingStepOptions.isolated_motion");
  icp.validate("TrackingStepOptions.icp");
  if (!(hold_min_scored_share >= 0.f && hold_min_scored_share <= 1.f)) {
    throw std::invalid_argument("TrackingStepOptions.hold_min_scored_share must be in [0, 1], got " +
                                std::to_string(hold_min_scored_share));
  }
  if (!(max_hold_frames >= 1 && max_hold_frames <= 100000)) {
    throw std::invalid_argument("TrackingStepOptions.max_hold_frames must be in [1, 100000], got " +
                                std::to_string(max_hold_frames));
  }
  if (!(last_pose_check_occluded_share >= 0.f && last_pose_check_occluded_share <= 1.f)) {
    throw std::invalid_argument("TrackingStepOptions.last_pose_check_occluded_share must be in [0, 1], got " +
                                std::to_string(last_pose_check_occluded_share));
  }
  needs_occlusion_test(last_pose_check_occluded_share > 0.f, "last_pose_check_occluded_share",
                       "the occluded share is measured there");
  require_in_range("TrackingStepOptions", "companion_turn_min", companion_turn_min, 0.0, std::numbers::pi, false);
  require_in_range("TrackingStepOptions", "companion_turn_min_cosine", companion_turn_min_cosine, -1.0, 1.0, false);
  require_in_range("TrackingStepOptions", "companion_turn_max_kept", companion_turn_max_kept, 0.0, 1.0, false);
  require_in_range("TrackingStepOptions", "predicted_start_min_turn", predicted_start_min_turn, 0.0, std::numbers::pi,
                   false);
  require_in_range("TrackingStepOptions", "predicted_start_min_shift", predicted_start_min_shift, 0.0, 1.0, false);
  needs_occlusion_test(predicted_start_min_turn > 0.f || predicted_start_min_shift > 0.f,
                       "predicted_start_min_turn or predicted_start_min_shift",
                       "the charge's seen-through share is measured there");
  if (!(last_pose_check_points >= 3 && last_pose_check_points <= 1000000)) {
    throw std::invalid_argument("TrackingStepOptions.last_pose_check_points must be in [3, 1000000], got " +
                                std::to_string(last_pose_check_points));
  }
}

TrackingStep::TrackingStep(const TrackingStepOptions& options)
    : options_(validated(options)),
      occlusion_(options.occlusion),
      fit_(options.fit),
      icp_(options.icp),
      last_pose_icp_([&] {
        IcpRefinementOptions sparse = options.icp;
        sparse.max_points = options.last_pose_check_points;
        return sparse;
      }()),
      claimed_hash_(std::max(options.exclude_claimed_radius, 1e-3f)),
      own_(std::max(options.exclude_claimed_radius, 1e-3f)) {}

void TrackingStep::set_claimed_points(std::span<const Eigen::Vector3f> points) {
  claimed_points_.assign(points.begin(), points.end());
  claimed_hash_.build(claimed_points_);
}

TrackingStepResult TrackingStep::track(const ColoredCloud& scene, const ObjectModel& model,
                                       const Eigen::AlignedBox3f& model_box, ParticleFilter& filter,
                                       Likelihood& likelihood) {
  TrackingStepResult result;
  const Pose last = filter.estimate();
  const PoseVector last_motion = filter.velocity();  // dX before this step: the prediction of step 5f
  const bool tests_occlusion = options_.hold_occluded_share > 0.f;
  if (tests_occlusion) {
    occlusion_.set_model(model.cloud.positions, last);  // once for both questions (steps 1 and 3)
    occlusion_.set_scene(scene.positions);
    result.occluded_share = occlusion_.occluded_share();
    if (result.occluded_share >= options_.hold_occluded_share) {
      if (held_in_row_ < options_.max_hold_frames) {
        hold(filter, result);
        return result;
      }
      result.hold_expired = true;
    }
  }
  select_hypothesis_points(scene, model_box, last, options_.hypothesis, hypothesis_);
  if (tests_occlusion && !result.hold_expired) {
    result.occluders_removed = occlusion_.remove_occluders(hypothesis_);
  }
  if (options_.exclude_claimed_radius > 0.f && !claimed_points_.empty()) {
    result.claimed_removed = remove_claimed(model, last);
  }
  if (!result.hold_expired) {
    const bool too_few = static_cast<float>(hypothesis_.points.size()) <
                         options_.hold_min_scored_share * static_cast<float>(model.cloud.size());
    if (!too_few) {
      held_in_row_ = 0;
    } else if (held_in_row_ < options_.max_hold_frames) {
      hold(filter, result);
      return result;
    } else {
      result.hold_expired = true;
    }
  }
  hypothesis_.features = compute_smr(hypothesis_.colors, options_.smr);
  result.hypothesis_points = hypothesis_.points.size();
  result.isolated = options_.exclude_claimed_radius > 0.f && claimed_points_.empty();
  const PoseVector* companion = companion_motion_ ? &*companion_motion_ : nullptr;
  result.companion = companion != nullptr;
  result.estimate = filter.step(hypothesis_, likelihood,
                                result.isolated ? options_.isolated_motion : filter.options().step_motion(), companion);
  const Pose filtered = result.estimate;
  if (options_.icp.iterations > 0) {
    const IcpResult icp =
        icp_.refine(hypothesis_.points, hypothesis_.features, model.cloud.positions, model.features, result.estimate);
    result.icp_refined = icp.refined;
    if (icp.refined) result.estimate = filter.replace_estimate(icp.pose);
  }
  // 5c / 5d: the last estimate, where no companion moves the object, else moved by the companion's motion.
  if (options_.last_pose_check_occluded_share > 0.f &&
      result.occluded_share >= options_.last_pose_check_occluded_share) {
    const Pose start = result.companion ? apply_increment(last, *companion) : last;
    if (const std::optional<Pose> kept = better_start(model, start, result.estimate)) {
      result.estimate = filter.replace_estimate(*kept);
      (result.companion ? result.companion_pose_kept : result.last_pose_kept) = true;
    }
  } else if (options_.predicted_start_min_turn > 0.f || options_.predicted_start_min_shift > 0.f) {
    // 5f: the constant-velocity prediction, where it lies apart from the estimate.
    const Pose predicted = apply_increment(last, last_motion);
    if (lies_apart(predicted, result.estimate)) {
      if (const std::optional<Pose> kept = better_start(model, predicted, result.estimate)) {
        result.estimate = filter.replace_estimate(*kept);
        result.predicted_start_kept = true;
      }
    }
  }
  // 5e: the filter's turn, where the companion turned the same way and the refinement turned it back.
  if (companion != nullptr && options_.companion_turn_min > 0.f &&
      keeps_filter_turn(last, filtered, result.estimate, *companion)) {
    Pose turned = result.estimate;
    turned.rotation = filtered.rotation;
    result.estimate = filter.replace_estimate(turned);
    result.companion_turn_kept = true;
  }
  result.fit = fit_.fit(hypothesis_, model, model_box, result.estimate);
  if (options_.confidence_seen_through_weight > 0.f) {  // the scene's rays are indexed (validate)
    result.seen_through_share =
        occlusion_.seen_through_share(model.cloud.positions, result.estimate, EstimateFit::kScoredPoints);
  }
  result.confidence = last_confidence_ =
      result.fit * std::max(0.f, 1.f - options_.confidence_seen_through_weight * result.seen_through_share);
  return result;
}

std::optional<Pose> TrackingStep::better_start(const ObjectModel& model, const Pose& start_pose, const Pose& estimate) {
  const std::span<const Eigen::Vector3f> points = model.cloud.positions;
  Pose start = start_pose;
  if (options_.icp.iterations > 0) {
    const IcpResult refined =
        last_pose_icp_.refine(hypothesis_.points, hypothesis_.features, points, model.features, start_pose);
    if (refined.refined) start = refined.pose;
  }
  // Both shares count points (scene points not on the model, model points where the view sees past them).
  const int n = options_.last_pose_check_points;
  const auto unexplained = [&](const Pose& pose) {
    return last_pose_icp_.unexplained(hypothesis_.points, hypothesis_.features, points, model.features, pose, n) +
           occlusion_.seen_through_share(points, pose, n);
  };
  if (unexplained(start) < unexplained(estimate)) return start;
  return std::nullopt;
}

bool TrackingStep::lies_apart(const Pose& a, const Pose& b) const {
  const float shift = (a.translation - b.translation).norm();
  const float turn = a.rotation.angularDistance(b.rotation);
  return (options_.predicted_start_min_shift > 0.f && shift >= options_.predicted_start_min_shift) ||
         (options_.predicted_start_min_turn > 0.f && turn >= options_.predicted_start_min_turn);
}

bool TrackingStep::keeps_filter_turn(const Pose& last, const Pose& filtered, const Pose& refined,
                                     const PoseVector& companion) const {
  // Turns as rotation vectors in the camera frame, composed on the left of the last estimate (apply_increment's
  // convention). Called only with companion_turn_min > 0, so both turns are non-zero past the first test.
  const Eigen::Quaternionf from_last = last.rotation.conjugate();
  const Eigen::Vector3f filter_turn = rotation_vector(Eigen::AngleAxisf(filtered.rotation * from_last));
  const Eigen::Vector3f companion_turn = rotation_vector(Eigen::AngleAxisf(rotation_from_rpy(companion.tail<3>())));
  const float filter_angle = filter_turn.norm();
  const float companion_angle = companion_turn.norm();
  if (!(filter_angle >= options_.companion_turn_min && companion_angle >= options_.companion_turn_min)) {
    return false;  // too small, or NaN
  }
  if (filter_turn.dot(companion_turn) < options_.companion_turn_min_cosine * filter_angle * companion_angle)
    return false;
  // The share of the filter's turn that the refined estimate kept, along the filter's axis.
  const Eigen::Vector3f refined_turn = rotation_vector(Eigen::AngleAxisf(refined.rotation * from_last));
  const float kept = refined_turn.dot(filter_turn) / (filter_angle * filter_angle);
  return kept < options_.companion_turn_max_kept;
}

void TrackingStep::hold(ParticleFilter& filter, TrackingStepResult& result) {
  ++held_in_row_;
  hypothesis_.points.clear();
  hypothesis_.features.clear();
  hypothesis_.colors.clear();
  result.estimate = filter.hold();
  result.held = true;
  result.confidence =
      last_confidence_ * std::exp2(-static_cast<float>(held_in_row_) / options_.hold_confidence_half_life);
}

std::size_t TrackingStep::remove_claimed(const ObjectModel& model, const Pose& last) {
  const float radius = options_.exclude_claimed_radius;
  own_points_.clear();
  for (const Eigen::Vector3f& m : model.cloud.positions) own_points_.push_back(last.rotation * m + last.translation);
  own_.build(own_points_);
  std::size_t kept = 0;
  const std::size_t n = hypothesis_.points.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f& p = hypothesis_.points[i];
    float other_sq = 0.f;
    bool claimed = claimed_hash_.nearest(p, radius, &other_sq) >= 0;
    if (claimed) {
      float own_sq = 0.f;
      if (own_.nearest(p, std::sqrt(other_sq), &own_sq) >= 0 && own_sq <= other_sq) claimed = false;
    }
    if (claimed) continue;
    hypothesis_.points[kept] = p;
    hypothesis_.colors[kept] = hypothesis_.colors[i];
    ++kept;
  }
  hypothesis_.points.resize(kept);
  hypothesis_.colors.resize(kept);
  return n - kept;
}

}  // namespace mfot
