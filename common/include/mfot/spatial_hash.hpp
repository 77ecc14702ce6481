#pragma once
// Uniform-grid spatial hash for bounded-radius nearest-neighbour queries. Exact within the
// query radius, deterministic (ties go to the lower point index), O(1) expected per query for
// the radii the method uses (tau = 10 mm segmentation, point-to-point correspondences).

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

namespace mfot {

class SpatialHash {
 public:
  // cell_size in metres; queries with max_distance <= cell_size / 2 visit 8 cells at most,
  // max_distance <= cell_size 27. Points with non-finite coordinates are never returned.
  explicit SpatialHash(float cell_size);

  void build(std::span<const Eigen::Vector3f> points);
  std::size_t size() const;

  // Index of the nearest point within max_distance of q, or -1. squared_distance gets its
  // squared distance when not null.
  int nearest(const Eigen::Vector3f& q, float max_distance, float* squared_distance = nullptr) const;

  // Appends to out the indices of all points within radius of q, in increasing index order.
  void radius_search(const Eigen::Vector3f& q, float radius, std::vector<int>& out) const;

 private:
  // Two cell layouts, chosen per build. Dense: when the bounding box of the points spans few
  // enough cells (a scene, or a few models), cell offsets form a 3-D array in x-fastest order,
  // so the cells of one x-row are contiguous and a query reads one span per (y, z) row. Sparse
  // (far-flung points): cells live in an open-addressing table (linear probing, power-of-two
  // capacity, at most half full). Queries allocate in neither.
  struct CellRange {
    int begin = 0;  // [begin, end) in sorted_points_ / sorted_index_
    int end = 0;
  };
  static constexpr std::uint64_t kEmptyKey = ~std::uint64_t{0};

  std::array<int, 3> cell_of(const Eigen::Vector3f& p) const;
  const CellRange* find_cell(int cx, int cy, int cz) const;
  void build_dense();
  void build_sparse();
  // Calls visit(slot) for every slot of sorted_points_ that may lie within radius of q.
  template <class Visit>
  void for_each_candidate(const Eigen::Vector3f& q, float radius, Visit&& visit) const;

  float cell_size_;
  float inv_cell_;
  std::size_t size_ = 0;
  std::vector<Eigen::Vector3f> sorted_points_;  // the finite points, grouped by cell
  std::vector<int> sorted_index_;               // their input indices, increasing within a cell
  std::vector<int> finite_scratch_;             // build: input indices of the finite points
  std::vector<std::array<int, 3>> cell_scratch_;  // build: their cells
  bool dense_ = false;
  std::array<int, 3> grid_lo_{0, 0, 0};
  std::array<int, 3> grid_dims_{0, 0, 0};
  std::vector<int> cell_start_;  // dense: offset of every cell's first slot, plus the total
  std::vector<std::uint64_t> table_keys_;  // sparse: kEmptyKey marks a free slot
  std::vector<CellRange> table_ranges_;
  std::vector<std::pair<std::uint64_t, int>> key_scratch_;  // sparse build: (cell key, finite rank)
  std::size_t cell_count_ = 0;
  std::size_t table_mask_ = 0;
};

}  // namespace mfot
