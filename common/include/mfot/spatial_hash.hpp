#pragma once
// Uniform-grid spatial hash for bounded-radius nearest-neighbour queries. Exact within the
// query radius, deterministic (ties go to the lower point index), O(1) expected per query for
// the radii the method uses (tau = 10 mm segmentation, point-to-point correspondences).

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

namespace mfot {

namespace spatial_hash_detail {

// Cell coordinates are clamped to 21 signed bits so three of them pack into one 64-bit key.
// Clamping is monotone, so a query box still contains every cell of a point inside it; with
// 10 mm cells the unclamped range is +-10 km.
constexpr int kCoordBits = 21;
constexpr float kCoordMin = -static_cast<float>(1 << (kCoordBits - 1));
constexpr float kCoordMax = static_cast<float>((1 << (kCoordBits - 1)) - 1);

inline int clamped_cell(float scaled) { return static_cast<int>(std::clamp(std::floor(scaled), kCoordMin, kCoordMax)); }

inline bool is_finite(const Eigen::Vector3f& p) {
  return std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z());
}

}  // namespace spatial_hash_detail

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
  // The same answer as nearest, looking within max_distance / 2 first (the nearest point within the half
  // radius is the nearest within the whole). With max_distance the cell size, a query with a point that
  // close reads 8 cells instead of 27 and one without reads 8 more: for queries that mostly find one
  // near (a scene against the models it came from).
  int nearest_near_first(const Eigen::Vector3f& q, float max_distance, float* squared_distance = nullptr) const;

  // The same point as nearest (or -1), plus what lets a caller whose query point moves skip the next query:
  // squared_distance gets its squared distance, others_squared_bound a lower bound on the squared distance
  // from q to every other point (to every point when -1): the least of max_distance and the distances of the
  // other points the query looked at. While q has moved by at most m, the same point stays the nearest
  // (ties excluded) as long as sqrt(squared_distance) + 2 m < sqrt(others_squared_bound).
  int nearest_with_bound(const Eigen::Vector3f& q, float max_distance, float& squared_distance,
                         float& others_squared_bound) const;

  // Appends to out the indices of all points within radius of q, in increasing index order.
  void radius_search(const Eigen::Vector3f& q, float radius, std::vector<int>& out) const;

  // Whether some point within radius of q satisfies pred(index); stops at the first (in no set order).
  template <class Pred>
  bool any_within(const Eigen::Vector3f& q, float radius, Pred&& pred) const;
  bool any_within(const Eigen::Vector3f& q, float radius) const {
    return any_within(q, radius, [](int) { return true; });
  }

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
  // Calls visit(slot) for every slot of sorted_points_ that may lie within radius of q, until one returns
  // true (then returns true).
  template <class Visit>
  bool for_each_candidate(const Eigen::Vector3f& q, float radius, Visit&& visit) const;

  float cell_size_;
  float inv_cell_;
  std::size_t size_ = 0;
  std::vector<Eigen::Vector3f> sorted_points_;    // the finite points, grouped by cell
  std::vector<int> sorted_index_;                 // their input indices, increasing within a cell
  std::vector<int> finite_scratch_;               // build: input indices of the finite points
  std::vector<std::array<int, 3>> cell_scratch_;  // build: their cells
  bool dense_ = false;
  std::array<int, 3> grid_lo_{0, 0, 0};
  std::array<int, 3> grid_dims_{0, 0, 0};
  std::vector<int> cell_start_;            // dense: offset of every cell's first slot, plus the total
  std::vector<std::uint64_t> table_keys_;  // sparse: kEmptyKey marks a free slot
  std::vector<CellRange> table_ranges_;
  std::vector<std::pair<std::uint64_t, int>> key_scratch_;  // sparse build: (cell key, finite rank)
  std::size_t cell_count_ = 0;
  std::size_t table_mask_ = 0;
};

inline std::array<int, 3> SpatialHash::cell_of(const Eigen::Vector3f& p) const {
  using spatial_hash_detail::clamped_cell;
  return {clamped_cell(p.x() * inv_cell_), clamped_cell(p.y() * inv_cell_), clamped_cell(p.z() * inv_cell_)};
}

template <class Visit>
inline bool SpatialHash::for_each_candidate(const Eigen::Vector3f& q, float radius, Visit&& visit) const {
  using spatial_hash_detail::is_finite;
  if (sorted_points_.empty() || !(radius >= 0.f) || !is_finite(q)) return false;
  // The small pad keeps points whose float distance rounds down to the radius inside the box.
  const Eigen::Vector3f r = Eigen::Vector3f::Constant(radius * 1.0001f + 1e-7f);
  auto lo = cell_of(q - r);
  auto hi = cell_of(q + r);

  if (dense_) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::max(lo[a], grid_lo_[a]) - grid_lo_[a];
      hi[a] = std::min(hi[a], grid_lo_[a] + grid_dims_[a] - 1) - grid_lo_[a];
      if (lo[a] > hi[a]) return false;
    }
    for (int cz = lo[2]; cz <= hi[2]; ++cz) {
      for (int cy = lo[1]; cy <= hi[1]; ++cy) {
        const std::size_t row = (static_cast<std::size_t>(cz) * grid_dims_[1] + cy) * grid_dims_[0];
        const int end = cell_start_[row + hi[0] + 1];
        for (int s = cell_start_[row + lo[0]]; s < end; ++s) {
          if (visit(s)) return true;
        }
      }
    }
    return false;
  }

  const double volume = (static_cast<double>(hi[0]) - lo[0] + 1) * (static_cast<double>(hi[1]) - lo[1] + 1) *
                        (static_cast<double>(hi[2]) - lo[2] + 1);
  // A box wider than the occupied cells is cheaper to answer by scanning every point.
  if (volume > static_cast<double>(cell_count_)) {
    for (int s = 0; s < static_cast<int>(sorted_points_.size()); ++s) {
      if (visit(s)) return true;
    }
    return false;
  }
  for (int cz = lo[2]; cz <= hi[2]; ++cz) {
    for (int cy = lo[1]; cy <= hi[1]; ++cy) {
      for (int cx = lo[0]; cx <= hi[0]; ++cx) {
        const CellRange* cell = find_cell(cx, cy, cz);
        if (cell == nullptr) continue;
        for (int s = cell->begin; s < cell->end; ++s) {
          if (visit(s)) return true;
        }
      }
    }
  }
  return false;
}

template <class Pred>
bool SpatialHash::any_within(const Eigen::Vector3f& q, float radius, Pred&& pred) const {
  const float r2 = radius * radius;
  return for_each_candidate(q, radius, [&](int s) {
    return (sorted_points_[static_cast<std::size_t>(s)] - q).squaredNorm() <= r2 &&
           pred(sorted_index_[static_cast<std::size_t>(s)]);
  });
}

}  // namespace mfot
