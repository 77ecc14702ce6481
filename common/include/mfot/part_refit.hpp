#pragma once
// Keeps a grown model consistent with its first view: each part grown since (a departure; the thesis's
// model is its first view, updated in place) was placed with its frame's pose estimate, errors included.
// A box that tumbles shows a new face just as the faces the model holds turn edge-on, so that pose is
// the least certain of all: a face grown a few degrees off later holds the estimate as far off whenever
// it fills the view, while the first view still places the object well (docs/departures.md). Where a frame shows the
// first view and a grown part well, the part's misplacement is measured and undone, as a loop closure re-places a SLAM
// map's keyframes (here the first view is the fixed keyframe). Steps of refit():
//  1. pair each of the object's segmented scene points with its nearest model point within
//     icp.max_distance at the pose estimate; the point belongs to that point's part;
//  2. a part takes part when it is seen well: at least min_points scene points, not lying along a
//     strip (the second largest standard deviation of their positions at least min_spread: an edge-on
//     face does not hold the rotation about its long axis), and covering at least min_coverage of the
//     part's model points (a scene point within icp.max_distance of them): a face seen only in part
//     does not hold its place along itself, so its registration slides and the object's frame would
//     drift with it. Nothing moves unless the first view and at least one grown part take part;
//  3. the first view (part 0) alone is registered on its scene points by ICP from the estimate
//     (IcpRefinement, point to point): the pose that the object's frame, as first seen, gives;
//  4. each grown part alone is registered on its scene points by ICP from that pose; the difference
//     of the two poses is the part's misplacement in the object frame;
//  5. the misplacement keeps only the rotations that the first view's registration holds (with
//     min_held_rotation > 0): it holds a rotation when turning by it moves its paired model points along
//     their normals (point to plane, the translation left free). A box whose first view shows well only
//     by its top holds no turn about the vertical, whatever point-to-point ICP's sampled faces pair with:
//     such a turn would hand a lagging estimate on to the grown face. The rotations are the eigenvectors of
//     the registration's rotational information (point-to-plane normal equations per pair, the translation
//     marginalised); one is held when its lever (square root of its eigenvalue, metres) is at least
//     min_held_rotation times the strongest's. The rest of the misplacement's rotation is dropped; the
//     part's centroid still moves as measured. (A grown part's own registration is not judged so: a whole
//     face, which min_coverage asks for, holds its turn within its plane by its edges);
//  6. a part misplaced by at least min_rotation or min_translation is moved by it (smaller ones are
//     the fit's noise); an ICP refused (too few pairs, a correction beyond icp.max_rotation /
//     icp.max_translation) moves nothing.
// Deterministic, no random draws. Non-copyable: it owns the model hash, the ICPs, the part buffers and the
// first views' normals.

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "mfot/icp_refinement.hpp"
#include "mfot/spatial_hash.hpp"
#include "mfot/types.hpp"

namespace mfot {

// Member defaults: for library users and unit tests; the services set min_rotation and icp's min_paired_share,
// max_rotation and max_points (docs/method.md, Constants).
struct PartRefitOptions {
  int min_points = 150;            // scene points a part needs to take part [3, 1000000]
  float min_spread = 0.01f;        // their second largest standard deviation, metres [0, 1]
  float min_coverage = 0.5f;       // share of the part's model points they come near [0, 1]
  float min_rotation = 0.0087f;    // a smaller misplacement is left: radians [0, pi] ...
  float min_translation = 0.002f;  // ... and metres [0, 1] (moved when either is reached)
  // Step 5: a rotation is held by the first view when its lever is at least this share of the strongest's
  // [0, 1]; 0 = the misplacement's whole rotation is kept.
  float min_held_rotation = 0.5f;
  // Steps 3 and 4 (iterations, pairing distance, least paired share, largest correction, points).
  IcpRefinementOptions icp = [] {
    IcpRefinementOptions o;
    o.iterations = 10;  // > 0: a registration
    return o;
  }();
  // Throws std::invalid_argument naming the field as owner.field.
  void validate(const std::string& owner = "PartRefitOptions") const;
};

class PartRefit {
 public:
  explicit PartRefit(const PartRefitOptions& options = {});
  PartRefit(const PartRefit&) = delete;
  PartRefit& operator=(const PartRefit&) = delete;

  const PartRefitOptions& options() const { return options_; }

  // segmented: the object's scene points this frame, camera frame. model: object frame, moved in place.
  // part_ends: the model's parts as the end index of each (ascending, the last one model.size(); part 0
  // is the first view), else std::invalid_argument. estimate: object -> camera. Returns the parts moved.
  std::size_t refit(std::span<const Eigen::Vector3f> segmented, std::span<Eigen::Vector3f> model,
                    std::span<const std::uint32_t> part_ends, const Pose& estimate);

 private:
  PartRefitOptions options_;
  SpatialHash model_hash_;
  SpatialHash segmented_hash_;
  std::vector<Eigen::Vector3f> segmented_local_;
  IcpRefinement first_view_icp_;
  IcpRefinement part_icp_;
  std::vector<std::vector<Eigen::Vector3f>> part_scene_;  // per part: its scene points, camera frame
  std::vector<std::size_t> seen_parts_;                   // the grown parts seen well (step 2)
  // Step 5's normals, per first view seen lately (one per object; a first view's points never move, so its normals
  // are computed once each, when first paired): NaN until then.
  struct NormalCache {
    std::vector<Eigen::Vector3f> points;
    std::vector<Eigen::Vector3f> normals;
  };
  static constexpr std::size_t kNormalCacheSize = 64;
  std::vector<NormalCache> normal_cache_;
  std::vector<int> neighbours_;
  std::vector<Eigen::Vector3f>& first_view_normals(std::span<const Eigen::Vector3f> first_view);
  // Step 5: the projector onto the rotations (object frame) that the registration of the first view (the
  // model's points before first_view_end) on these scene points (camera frame) at this pose holds.
  Eigen::Matrix3d first_view_rotations(std::span<const Eigen::Vector3f> scene, std::span<const Eigen::Vector3f> model,
                                       std::uint32_t first_view_end, const Pose& pose);
};

}  // namespace mfot
