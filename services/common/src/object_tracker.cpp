#include "mfot/service/object_tracker.hpp"

#include <stdexcept>

#include "mfot/hypothesis.hpp"

namespace mfot::service {

ObjectTracker::ObjectTracker(const ObjectTrackerOptions& options)
    : options_(options), likelihood_(make_likelihood(options.likelihood)), step_(options.step) {
  const ParticleFilter validate_only(options_.filter);  // the filter validates its options
}

bool ObjectTracker::set_model(std::int32_t object_id, std::int32_t version, const ObjectModel& model, const Pose& pose,
                              bool carried) {
  const bool new_object = object_id != object_id_ || filter_ == nullptr;
  if (new_object || version != version_) {  // else the model held: no new grid
    likelihood_.likelihood->set_model(model);
    ++grid_builds_;
    if (new_object) {
      ParticleFilterOptions filter_options = options_.filter;
      filter_options.seed = options_.filter.seed + static_cast<std::uint64_t>(object_id);
      filter_ = std::make_unique<ParticleFilter>(filter_options);
      filter_->reset(pose);
      step_.reset();
      object_id_ = object_id;
    }
    version_ = version;
    model_box_ = model_bounding_box(model);
    model_ = model;
  }
  if (carried && !new_object) filter_->move_to(pose);
  return new_object;
}

void ObjectTracker::carry_to(const Pose& pose) {
  if (filter_ == nullptr) throw std::logic_error("ObjectTracker::carry_to without an object");
  filter_->move_to(pose);
}

void ObjectTracker::drop() {
  filter_.reset();
  object_id_ = -1;
  // A worker lives long and takes objects in turn: what it held of the object goes with it (the
  // likelihood's grid and the model, megabytes for a large model), so an idle worker's memory does
  // not stay at the largest object it ever tracked. Every backend takes an empty model as none.
  likelihood_.likelihood->set_model(ObjectModel{});
  model_ = ObjectModel{};
  model_box_ = Eigen::AlignedBox3f();
  version_ = 0;
}

TrackingStepResult ObjectTracker::track(const ColoredCloud& scene) {
  if (filter_ == nullptr) throw std::logic_error("ObjectTracker::track without an object");
  return step_.track(scene, model_, model_box_, *filter_, *likelihood_.likelihood);
}

}  // namespace mfot::service
