#include "mfot/spatial_hash.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace mfot {

namespace {

using spatial_hash_detail::kCoordBits;

// The dense layout is used up to this many cells per point (and at least kDenseMinCells):
// 4 bytes per cell stay small next to the 16 bytes per point.
constexpr std::int64_t kDenseCellsPerPoint = 64;
constexpr std::int64_t kDenseMinCells = std::int64_t{1} << 18;
constexpr std::int64_t kDenseMaxCells = std::int64_t{1} << 24;

std::uint64_t pack_key(int cx, int cy, int cz) {
  constexpr std::uint64_t offset = std::uint64_t{1} << (kCoordBits - 1);
  constexpr std::uint64_t mask = (std::uint64_t{1} << kCoordBits) - 1;
  return ((static_cast<std::uint64_t>(cx) + offset) & mask) |
         (((static_cast<std::uint64_t>(cy) + offset) & mask) << kCoordBits) |
         (((static_cast<std::uint64_t>(cz) + offset) & mask) << (2 * kCoordBits));
}

// splitmix64 finaliser: every key bit reaches the low bits that pick the slot.
std::size_t hash_key(std::uint64_t key) {
  key ^= key >> 30;
  key *= 0xBF58476D1CE4E5B9ull;
  key ^= key >> 27;
  key *= 0x94D049BB133111EBull;
  key ^= key >> 31;
  return static_cast<std::size_t>(key);
}

using spatial_hash_detail::is_finite;

}  // namespace

SpatialHash::SpatialHash(float cell_size) : cell_size_(cell_size), inv_cell_(0.f) {
  if (!(cell_size > 0.f) || !std::isfinite(cell_size)) {
    throw std::invalid_argument("SpatialHash: cell_size must be finite and > 0, got " + std::to_string(cell_size));
  }
  inv_cell_ = 1.f / cell_size;
}

void SpatialHash::build(std::span<const Eigen::Vector3f> points) {
  size_ = points.size();
  finite_scratch_.clear();
  cell_scratch_.clear();
  std::array<int, 3> lo{0, 0, 0}, hi{0, 0, 0};
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!is_finite(points[i])) continue;
    const auto c = cell_of(points[i]);
    if (finite_scratch_.empty()) lo = hi = c;
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], c[a]);
      hi[a] = std::max(hi[a], c[a]);
    }
    finite_scratch_.push_back(static_cast<int>(i));
    cell_scratch_.push_back(c);
  }
  sorted_points_.resize(finite_scratch_.size());
  sorted_index_.resize(finite_scratch_.size());

  std::int64_t cells = 1;
  for (int a = 0; a < 3; ++a) {
    grid_lo_[a] = lo[a];
    grid_dims_[a] = hi[a] - lo[a] + 1;
    cells *= grid_dims_[a];
  }
  const auto n = static_cast<std::int64_t>(finite_scratch_.size());
  dense_ = cells <= std::min(kDenseMaxCells, std::max(kDenseMinCells, kDenseCellsPerPoint * n));
  if (dense_) {
    build_dense();
  } else {
    build_sparse();
  }
  for (std::size_t s = 0; s < sorted_index_.size(); ++s)
    sorted_points_[s] = points[static_cast<std::size_t>(sorted_index_[s])];
}

// Counting sort by linear cell index; visiting points in input order keeps each cell ascending.
void SpatialHash::build_dense() {
  const std::size_t cells = static_cast<std::size_t>(grid_dims_[0]) * grid_dims_[1] * grid_dims_[2];
  cell_start_.assign(cells + 1, 0);
  const auto linear = [&](const std::array<int, 3>& c) {
    return (static_cast<std::size_t>(c[2] - grid_lo_[2]) * grid_dims_[1] + (c[1] - grid_lo_[1])) * grid_dims_[0] +
           (c[0] - grid_lo_[0]);
  };
  for (const auto& c : cell_scratch_) ++cell_start_[linear(c) + 1];
  for (std::size_t k = 0; k < cells; ++k) cell_start_[k + 1] += cell_start_[k];
  // cell_start_[k] serves as the fill cursor of cell k, then is shifted back.
  for (std::size_t r = 0; r < finite_scratch_.size(); ++r) {
    sorted_index_[static_cast<std::size_t>(cell_start_[linear(cell_scratch_[r])]++)] = finite_scratch_[r];
  }
  for (std::size_t k = cells; k > 0; --k) cell_start_[k] = cell_start_[k - 1];
  cell_start_[0] = 0;
}

void SpatialHash::build_sparse() {
  key_scratch_.resize(finite_scratch_.size());
  for (std::size_t r = 0; r < finite_scratch_.size(); ++r) {
    const auto& c = cell_scratch_[r];
    key_scratch_[r] = {pack_key(c[0], c[1], c[2]), static_cast<int>(r)};
  }
  std::sort(key_scratch_.begin(), key_scratch_.end());

  cell_count_ = 0;
  for (std::size_t s = 0; s < key_scratch_.size(); ++s) {
    sorted_index_[s] = finite_scratch_[static_cast<std::size_t>(key_scratch_[s].second)];
    if (s == 0 || key_scratch_[s].first != key_scratch_[s - 1].first) ++cell_count_;
  }
  std::size_t capacity = 16;
  while (capacity < 2 * cell_count_) capacity *= 2;
  table_mask_ = capacity - 1;
  table_keys_.assign(capacity, kEmptyKey);
  table_ranges_.assign(capacity, CellRange{});

  std::size_t begin = 0;
  while (begin < key_scratch_.size()) {
    const std::uint64_t key = key_scratch_[begin].first;
    std::size_t end = begin + 1;
    while (end < key_scratch_.size() && key_scratch_[end].first == key) ++end;
    std::size_t slot = hash_key(key) & table_mask_;
    while (table_keys_[slot] != kEmptyKey) slot = (slot + 1) & table_mask_;
    table_keys_[slot] = key;
    table_ranges_[slot] = CellRange{static_cast<int>(begin), static_cast<int>(end)};
    begin = end;
  }
}

std::size_t SpatialHash::size() const { return size_; }

const SpatialHash::CellRange* SpatialHash::find_cell(int cx, int cy, int cz) const {
  const std::uint64_t key = pack_key(cx, cy, cz);
  std::size_t slot = hash_key(key) & table_mask_;
  while (true) {
    const std::uint64_t k = table_keys_[slot];
    if (k == key) return &table_ranges_[slot];
    if (k == kEmptyKey) return nullptr;
    slot = (slot + 1) & table_mask_;
  }
}

int SpatialHash::nearest(const Eigen::Vector3f& q, float max_distance, float* squared_distance) const {
  int best = -1;
  float best_d2 = max_distance * max_distance;
  for_each_candidate(q, max_distance, [&](int s) {
    const float d2 = (sorted_points_[static_cast<std::size_t>(s)] - q).squaredNorm();
    if (d2 > best_d2) return false;
    const int i = sorted_index_[static_cast<std::size_t>(s)];
    if (d2 < best_d2 || best < 0 || i < best) {
      best_d2 = d2;
      best = i;
    }
    return false;
  });
  if (best >= 0 && squared_distance != nullptr) *squared_distance = best_d2;
  return best;
}

int SpatialHash::nearest_near_first(const Eigen::Vector3f& q, float max_distance, float* squared_distance) const {
  const int near = nearest(q, 0.5f * max_distance, squared_distance);
  return near >= 0 ? near : nearest(q, max_distance, squared_distance);
}

int SpatialHash::nearest_with_bound(const Eigen::Vector3f& q, float max_distance, float& squared_distance,
                                    float& others_squared_bound) const {
  // Every point within max_distance is visited, so one that is not lies further: max_distance bounds them.
  const float max_d2 = max_distance * max_distance;
  int best = -1;
  float best_d2 = std::numeric_limits<float>::infinity();
  float second_d2 = max_d2;
  for_each_candidate(q, max_distance, [&](int s) {
    const float d2 = (sorted_points_[static_cast<std::size_t>(s)] - q).squaredNorm();
    const int i = sorted_index_[static_cast<std::size_t>(s)];
    if (best < 0 || d2 < best_d2 || (d2 == best_d2 && i < best)) {  // nearest's order: ties to the lower index
      if (best >= 0) second_d2 = std::min(second_d2, best_d2);
      best_d2 = d2;
      best = i;
    } else {
      second_d2 = std::min(second_d2, d2);
    }
    return false;
  });
  if (best >= 0 && best_d2 > max_d2) {  // looked at, but further than max_distance: none, as nearest says
    second_d2 = std::min(second_d2, best_d2);
    best = -1;
  }
  squared_distance = best_d2;
  others_squared_bound = second_d2;
  return best;
}

void SpatialHash::radius_search(const Eigen::Vector3f& q, float radius, std::vector<int>& out) const {
  const std::size_t first = out.size();
  const float r2 = radius * radius;
  for_each_candidate(q, radius, [&](int s) {
    if ((sorted_points_[static_cast<std::size_t>(s)] - q).squaredNorm() <= r2)
      out.push_back(sorted_index_[static_cast<std::size_t>(s)]);
    return false;
  });
  std::sort(out.begin() + static_cast<std::ptrdiff_t>(first), out.end());
}

}  // namespace mfot
