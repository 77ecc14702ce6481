#pragma once
// Incremental object model update with a forgetting factor, thesis 3.4.

#include <cstdint>
#include <random>
#include <span>
#include <vector>

#include "mfot/likelihood.hpp"
#include "mfot/smr_feature.hpp"
#include "mfot/spatial_hash.hpp"
#include "mfot/types.hpp"

namespace mfot {

struct ModelUpdateOptions {
  float alpha = 0.02f;     // [0, 1]: share of the new model drawn from the segmented points
  std::uint64_t seed = 1;  // seeds the updater's own generator
  // Size of every updated model: 0 keeps the size of the model being updated (the thesis's
  // "model size steady"); n > 0 steers every update to n points (a model smaller than n grows
  // towards it from the segmented points, a larger one shrinks).
  std::size_t target_size = 0;
  SmrOptions smr;  // colour feature of the points taken from the scene
  // > 0: only old points seen this frame (a segmented point within this distance, metres) are
  // forgotten, so the model keeps what is occluded (a hand covering half a box would otherwise
  // erase that half at alpha per frame). 0: the thesis's uniform draw over the whole old model.
  float seen_radius = 0.01f;
  void validate() const;
};

// Thesis 3.4: M_t = random alpha share of the points segmented for the object at t (moved into
// the object frame with X_t^-1)  +  random (1 - alpha) share of M_{t-1}. Steps:
//   1. n = target size (the old size by default); n_new = min(round(alpha n), #segmented);
//      n_old = min(n - n_new, #old); when still short of n, take more segmented points;
//   2. draw n_old old points and n_new segmented points uniformly without replacement from the
//      updater's seeded generator; old points keep their order and features, new ones follow;
//      with seen_radius > 0 every old point without a segmented point near it is kept and the
//      forgotten ones are drawn from the seen ones (n_new is capped by their number);
//   3. move the new points into the object frame with the inverse estimate and compute their
//      SMR features.
// alpha = 0 (with the default size policy) returns the old model unchanged. Rebuilding the
// likelihood's descriptor from the new model (Likelihood::set_model, i.e. J for JCSD) is the
// caller's job. One updater per object keeps each object's draws independent of the others.
class ModelUpdater {
 public:
  explicit ModelUpdater(const ModelUpdateOptions& options = {});
  ModelUpdater(const ModelUpdater&) = delete;
  ModelUpdater& operator=(const ModelUpdater&) = delete;

  const ModelUpdateOptions& options() const { return options_; }

  // segmented: the object's segmented scene points, camera frame. estimate: object -> camera.
  ObjectModel update(const ObjectModel& old_model, const ColoredCloud& segmented, const Pose& estimate);
  // Same, taking the points of scene whose label equals id (labels from the Segmenter).
  ObjectModel update(const ObjectModel& old_model, const ColoredCloud& scene, std::span<const std::int32_t> labels,
                     std::int32_t id, const Pose& estimate);

 private:
  ObjectModel mix(const ObjectModel& old_model, const ColoredCloud& source, const Pose& estimate);
  // Draws count distinct values from candidates_ (reordering it): they end up in its first count slots.
  void draw_without_replacement(std::vector<int>& candidates, std::size_t count);

  ModelUpdateOptions options_;
  std::mt19937_64 rng_;
  std::vector<int> new_candidates_;  // indices into the segmented points
  std::vector<int> old_candidates_;  // indices into the old model
  std::vector<int> unseen_;          // old model points without a segmented point near them
  std::vector<Eigen::Vector3f> segmented_in_object_;
  SpatialHash seen_hash_{0.01f};
  std::vector<Rgb8> new_colors_;
};

}  // namespace mfot
