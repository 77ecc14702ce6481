#pragma once
// Point-level boundaries between discovered parts, by colour. The discovery (object_discovery.hpp)
// labels whole supervoxels (seed_resolution, 2 cm shipped): where two touching objects' faces are nearly
// flush, a supervoxel that straddles the seam goes with all its points to one of them, and that
// strip stays in the wrong object's model for as long as the two touch. Along the seam the colour
// still tells the objects apart: a point near another part moves to it when the small patch around
// it continues a face of that part, in shape and in colour. The colour test is a likelihood ratio
// over the patch (one point's colour alone would also move the specks of a multicoloured print that
// match the neighbour), made twice: with the whole part's colours, then with the colours of the face
// the point continues (on real stacked boxes, a box's end face flush with the white end of the one
// below stays, though the lower box is yellow elsewhere, like that end face).
//
// Steps of PartBoundaryRefiner::refine:
//   1. the patch of every point: the points within radius / 3 (spatial hash);
//   2. seam points have a point of another part in their patch; every point within radius of a
//      seam (along the patches, Dijkstra) is on a border, facing that seam's other part; the
//      others are the parts' cores;
//   3. a colour model per part: a histogram over RGB (8 levels a channel, trilinear votes, one
//      pseudo-count per bin) of its core's points, or of all its points when its core holds fewer
//      than half of them (a thin part is all border);
//   4. a border point moves to the part it faces when, over the points of its patch in its own part,
//      a. the mean log-likelihood ratio of their colours, that part's model over their part's, is at
//         least log(min_color_ratio);
//      b. at least half of that part's points within radius lie on the plane of the patch (within
//         radius / 6): the point continues one of its faces (a concave edge is never crossed);
//      c. the colours of those points on the plane (a histogram as in 3) pass the same test as in a
//         against their part's model;
//      moves are decided on the labels before the pass, so the result does not depend on point order;
//   5. steps 2 and 4 repeat with the same models while points move, at most kMaxPasses times (a
//      point too far from the face for c's evidence moves once the points before it have).

#include <Eigen/Core>
#include <array>
#include <span>
#include <vector>

#include "mfot/spatial_hash.hpp"
#include "mfot/types.hpp"

namespace mfot {

struct PartBoundaryOptions {
  float radius = 0.f;           // metres, [0, 0.2]: how far from a seam points may move; 0 = off
  float min_color_ratio = 4.f;  // > 1: how many times better the other part's model must explain a patch
  void validate() const;        // throws std::invalid_argument naming the field and its range
};

class PartBoundaryRefiner {
 public:
  explicit PartBoundaryRefiner(const PartBoundaryOptions& options = {});
  PartBoundaryRefiner(const PartBoundaryRefiner&) = delete;
  PartBoundaryRefiner& operator=(const PartBoundaryRefiner&) = delete;

  const PartBoundaryOptions& options() const { return options_; }

  // part_of_point: per point its part in [0, parts), changed in place. Returns the number of
  // points whose part changed. Deterministic; does nothing with radius 0 or fewer than two parts.
  std::size_t refine(std::span<const Eigen::Vector3f> positions, std::span<const Rgb8> colors,
                     std::vector<int>& part_of_point);

 private:
  static constexpr int kLevels = 8;  // histogram levels per colour channel
  static constexpr int kMaxPasses = 4;
  using Histogram = std::array<float, kLevels * kLevels * kLevels>;

  // Step 2: facing_[i] = the part point i faces (-1: core), from the seams of part_of_point.
  void find_borders(std::span<const Eigen::Vector3f> positions, const std::vector<int>& part_of_point);
  // Step 4b and c: point i continues a face of part, in shape and in colour.
  bool continues_face_of(std::span<const Eigen::Vector3f> positions, std::span<const Rgb8> colors,
                         const std::vector<int>& part_of_point, std::size_t parts, std::size_t i, int part);
  // Steps 4a and c: over the points of i's patch in its own part, the mean of log_density_of(point) minus
  // their own part's log density is at least log(min_color_ratio).
  template <class LogDensity>
  bool patch_prefers(std::size_t i, const std::vector<int>& part_of_point, std::size_t parts,
                     LogDensity&& log_density_of) const;
  static void add_vote(Histogram& histogram, Rgb8 color);
  // Log density of a colour under a histogram of `votes` votes, with one pseudo-count per bin.
  static float log_density(const Histogram& histogram, float votes, Rgb8 color);

  PartBoundaryOptions options_;
  SpatialHash hash_;
  std::vector<int> patch_offsets_;  // point i's patch: patch_points_[patch_offsets_[i], patch_offsets_[i + 1])
  std::vector<int> patch_points_;
  std::vector<float> seam_distance_;
  std::vector<int> facing_;
  std::vector<float> log_density_;  // point i, part p: log_density_[i * parts + p]
  std::vector<int> next_;
  std::vector<int> neighbours_;
  Histogram local_model_{};
};

}  // namespace mfot
