#pragma once
// Uniform-grid spatial hash for bounded-radius nearest-neighbour queries. Exact within the
// query radius, deterministic (ties go to the lower point index), O(1) expected per query for
// the radii the method uses (tau = 10 mm segmentation, point-to-point correspondences).

#include <Eigen/Core>

#include <cstdint>
#include <span>
#include <unordered_map>
#include <vector>

namespace mfot {

class SpatialHash {
 public:
  // cell_size in metres; queries with max_distance <= cell_size visit 27 cells at most.
  explicit SpatialHash(float cell_size);

  void build(std::span<const Eigen::Vector3f> points);
  std::size_t size() const;

  // Index of the nearest point within max_distance of q, or -1. squared_distance gets its
  // squared distance when not null.
  int nearest(const Eigen::Vector3f& q, float max_distance, float* squared_distance = nullptr) const;

  // Appends to out the indices of all points within radius of q, in increasing index order.
  void radius_search(const Eigen::Vector3f& q, float radius, std::vector<int>& out) const;

 private:
  // implementation chosen by its author; keep it allocation-free per query
  float cell_size_;
  float inv_cell_;
  std::vector<Eigen::Vector3f> points_;
  std::vector<int> sorted_index_;                          // point indices grouped by cell
  std::unordered_map<std::uint64_t, std::pair<int, int>> cells_;  // cell key -> [begin, end) in sorted_index_
};

}  // namespace mfot
