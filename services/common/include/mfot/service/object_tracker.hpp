#pragma once
// One object's tracker, as a tracker worker and mfot-inprocess run it: the particle filter (thesis
// 2.2.2) over hypothesis data (3.3) scored by the likelihood (JCSD 3.20/3.21 on the GPU or CPU, or
// the point-to-point baseline), with mfot's occlusion handling (TrackingStep). Steps:
//   1. set_model: a new object gets a new filter, seeded with tracker.seed + its id and started at
//      the model's pose; the likelihood rebuilds its grid (and re-uploads it to the GPU) only when
//      the object or its model version changes (with merger.alpha 0 a model seldom changes, but it
//      comes with every frame);
//   2. track: TrackingStep on the scene (hold while hidden, hypothesis data, occluders left out,
//      SMR features of the scored points only, filter step).
// Deterministic (the filter owns the only generator). Non-copyable: it owns the likelihood (on the
// GPU a CUDA stream and device buffers) and the step's buffers.

#include <cstdint>
#include <memory>
#include <optional>

#include "mfot/cuda/likelihood_factory.hpp"
#include "mfot/particle_filter.hpp"
#include "mfot/tracking_step.hpp"

namespace mfot::service {

struct ObjectTrackerOptions {
  LikelihoodOptions likelihood;
  ParticleFilterOptions filter;  // seed: each object adds its id
  TrackingStepOptions step;
};

class ObjectTracker {
 public:
  // Chooses the likelihood backend (make_likelihood) and validates the options.
  explicit ObjectTracker(const ObjectTrackerOptions& options);
  ObjectTracker(const ObjectTracker&) = delete;
  ObjectTracker& operator=(const ObjectTracker&) = delete;

  // Step 1. True when `object_id` is new to this tracker. carried: the merger carried the hidden
  // object to `pose` (ManagedObject::carried_by, object_model_t.carried_by): an object already held
  // moves its whole particle set there (ParticleFilter::move_to); otherwise its filter keeps its own
  // estimate. A model the likelihood cannot take (e.g. a JCSD grid beyond its corner limit) throws
  // what the likelihood throws, and nothing changes.
  bool set_model(std::int32_t object_id, std::int32_t version, const ObjectModel& model, const Pose& pose,
                 bool carried = false);
  // The merger carried the hidden object held to `pose` (as set_model with `carried`, model kept):
  // the whole particle set moves there.
  void carry_to(const Pose& pose);
  // The object went to another tracker or was retired: its filter, model and the likelihood's grid
  // are released (has_object() false, model() empty).
  void drop();
  // The other objects' model points at their last poses (camera frame), for the step's
  // exclude_claimed_radius.
  void set_claimed_points(std::span<const Eigen::Vector3f> points) { step_.set_claimed_points(points); }
  // A touching object's motion given to this object (ManagedObject::companion_motion), for the
  // filter's companion_fraction; nullopt = none.
  void set_companion_motion(const std::optional<PoseVector>& motion) { step_.set_companion_motion(motion); }
  // The image the scenes come from (Scene::view), for the step's seen-through share; nullopt = unknown.
  void set_view(const std::optional<ViewBounds>& view) { step_.set_view(view); }
  // Step 2, on the object held (has_object()).
  TrackingStepResult track(const ColoredCloud& scene);

  bool has_object() const { return filter_ != nullptr; }
  std::int32_t object_id() const { return object_id_; }
  std::int32_t model_version() const { return version_; }
  const ObjectModel& model() const { return model_; }
  const ParticleFilter& filter() const { return *filter_; }
  const LikelihoodChoice& likelihood() const { return likelihood_; }
  // Grids built so far (Likelihood::set_model calls).
  std::int64_t grid_builds() const { return grid_builds_; }

 private:
  ObjectTrackerOptions options_;
  LikelihoodChoice likelihood_;
  TrackingStep step_;
  std::unique_ptr<ParticleFilter> filter_;
  std::int32_t object_id_ = -1;
  std::int32_t version_ = 0;
  ObjectModel model_;
  Eigen::AlignedBox3f model_box_;
  std::int64_t grid_builds_ = 0;
};

}  // namespace mfot::service
