#pragma once
// Nearest-neighbour segmentation of the scene by the tracked objects, thesis 3.4, equations
// 3.22 and 3.23.

#include <cstdint>
#include <span>
#include <vector>

#include "mfot/spatial_hash.hpp"
#include "mfot/thread_pool.hpp"
#include "mfot/types.hpp"

namespace mfot {

struct SegmentationOptions {
  float tau = 0.010f;  // metres, (0, 1]: 2 x the 5 mm voxel leaf (3.23)
  void validate() const;
};

// One tracked object as the segmenter sees it. The spans must stay valid for the call.
struct SegmentationObject {
  std::int32_t id = 0;                            // > 0 and unique; 0 means "no object"
  std::span<const Eigen::Vector3f> model_points;  // object frame, metres
  Pose pose;                                      // estimate, object -> camera
};

struct SegmentationResult {
  std::vector<std::int32_t> labels;      // per scene point: object id, 0 = no object
  std::vector<std::int32_t> object_ids;  // the objects in input order
  std::vector<std::size_t> counts;       // per object (input order): scene points labelled with it
};

// Thesis 3.4, 3.22-3.23: every scene point is labelled with the object whose nearest model
// point, in the estimated pose, is closest, if that distance is at most tau; otherwise 0.
// Steps per call:
//   1. move every model into the camera frame with its estimate X_t (one combined point set,
//      each point tagged with its object);
//   2. index the combined set once (spatial hash, cell = tau);
//   3. for every scene point find the nearest model point within tau and take its object.
// All objects compete at once, so a point between two touching objects goes to the closer
// model. Exact ties go to the object listed first.
class Segmenter {
 public:
  explicit Segmenter(const SegmentationOptions& options = {});
  Segmenter(const Segmenter&) = delete;
  Segmenter& operator=(const Segmenter&) = delete;

  const SegmentationOptions& options() const { return options_; }

  // Fills result (its buffers are reused). Throws std::invalid_argument for an id <= 0 or a
  // repeated id. With a pool, step 3 runs on ranges of scene points side by side (each point's label
  // is its own): the result is the same for any thread count.
  void segment(std::span<const Eigen::Vector3f> scene_points, std::span<const SegmentationObject> objects,
               SegmentationResult& result, ThreadPool* pool = nullptr);

 private:
  SegmentationOptions options_;
  SpatialHash hash_;
  std::vector<Eigen::Vector3f> model_points_camera_;  // all models, camera frame
  std::vector<std::int32_t> owner_;                   // index into objects per model point
};

// Copies the scene points (and colours) labelled with id into out (cleared first).
void gather_segment(const ColoredCloud& scene, std::span<const std::int32_t> labels, std::int32_t id,
                    ColoredCloud& out);

}  // namespace mfot
