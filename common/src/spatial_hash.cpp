#include "mfot/spatial_hash.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace mfot {

namespace {

// Cell coordinates are clamped to 21 signed bits so three of them pack into one 64-bit key.
// Clamping is monotone, so a query box still contains every cell of a point inside it; with
// 10 mm cells the unclamped range is +-10 km.
constexpr int kCoordBits = 21;
constexpr float kCoordMin = -static_cast<float>(1 << (kCoordBits - 1));
constexpr float kCoordMax = static_cast<float>((1 << (kCoordBits - 1)) - 1);

int clamped_cell(float scaled) {
  return static_cast<int>(std::clamp(std::floor(scaled), kCoordMin, kCoordMax));
}

std::uint64_t pack_key(int cx, int cy, int cz) {
  constexpr std::uint64_t offset = std::uint64_t{1} << (kCoordBits - 1);
  constexpr std::uint64_t mask = (std::uint64_t{1} << kCoordBits) - 1;
  return ((static_cast<std::uint64_t>(cx) + offset) & mask) |
         (((static_cast<std::uint64_t>(cy) + offset) & mask) << kCoordBits) |
         (((static_cast<std::uint64_t>(cz) + offset) & mask) << (2 * kCoordBits));
}

std::size_t hash_key(std::uint64_t key) {
  std::uint64_t h = key * 0x9E3779B97F4A7C15ull;
  h ^= h >> 31;
  return static_cast<std::size_t>(h);
}

bool is_finite(const Eigen::Vector3f& p) { return std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z()); }

}  // namespace

SpatialHash::SpatialHash(float cell_size) : cell_size_(cell_size), inv_cell_(0.f) {
  if (!(cell_size > 0.f) || !std::isfinite(cell_size)) {
    throw std::invalid_argument("SpatialHash: cell_size must be finite and > 0, got " + std::to_string(cell_size));
  }
  inv_cell_ = 1.f / cell_size;
}

std::array<int, 3> SpatialHash::cell_of(const Eigen::Vector3f& p) const {
  return {clamped_cell(p.x() * inv_cell_), clamped_cell(p.y() * inv_cell_), clamped_cell(p.z() * inv_cell_)};
}

void SpatialHash::build(std::span<const Eigen::Vector3f> points) {
  points_.assign(points.begin(), points.end());

  build_scratch_.clear();
  build_scratch_.reserve(points_.size());
  for (std::size_t i = 0; i < points_.size(); ++i) {
    if (!is_finite(points_[i])) continue;
    const auto c = cell_of(points_[i]);
    build_scratch_.emplace_back(pack_key(c[0], c[1], c[2]), static_cast<int>(i));
  }
  std::sort(build_scratch_.begin(), build_scratch_.end());

  sorted_index_.resize(build_scratch_.size());
  cell_count_ = 0;
  for (std::size_t i = 0; i < build_scratch_.size(); ++i) {
    sorted_index_[i] = build_scratch_[i].second;
    if (i == 0 || build_scratch_[i].first != build_scratch_[i - 1].first) ++cell_count_;
  }

  std::size_t capacity = 16;
  while (capacity < 2 * cell_count_) capacity *= 2;
  table_mask_ = capacity - 1;
  table_keys_.assign(capacity, kEmptyKey);
  table_ranges_.assign(capacity, CellRange{});

  std::size_t begin = 0;
  while (begin < build_scratch_.size()) {
    const std::uint64_t key = build_scratch_[begin].first;
    std::size_t end = begin + 1;
    while (end < build_scratch_.size() && build_scratch_[end].first == key) ++end;
    std::size_t slot = hash_key(key) & table_mask_;
    while (table_keys_[slot] != kEmptyKey) slot = (slot + 1) & table_mask_;
    table_keys_[slot] = key;
    table_ranges_[slot] = CellRange{static_cast<int>(begin), static_cast<int>(end)};
    begin = end;
  }
}

std::size_t SpatialHash::size() const { return points_.size(); }

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

template <class Visit>
void SpatialHash::for_each_candidate(const Eigen::Vector3f& q, float radius, Visit&& visit) const {
  if (sorted_index_.empty() || !(radius >= 0.f) || !is_finite(q)) return;
  // The small pad keeps points whose float distance rounds down to the radius inside the box.
  const Eigen::Vector3f r = Eigen::Vector3f::Constant(radius * 1.0001f + 1e-7f);
  const auto lo = cell_of(q - r);
  const auto hi = cell_of(q + r);
  const double volume = (static_cast<double>(hi[0]) - lo[0] + 1) * (static_cast<double>(hi[1]) - lo[1] + 1) *
                        (static_cast<double>(hi[2]) - lo[2] + 1);
  // A box wider than the occupied cells is cheaper to answer by scanning every point.
  if (volume > static_cast<double>(cell_count_)) {
    for (const int i : sorted_index_) visit(i);
    return;
  }
  for (int cz = lo[2]; cz <= hi[2]; ++cz) {
    for (int cy = lo[1]; cy <= hi[1]; ++cy) {
      for (int cx = lo[0]; cx <= hi[0]; ++cx) {
        const CellRange* cell = find_cell(cx, cy, cz);
        if (cell == nullptr) continue;
        for (int k = cell->begin; k < cell->end; ++k) visit(sorted_index_[k]);
      }
    }
  }
}

int SpatialHash::nearest(const Eigen::Vector3f& q, float max_distance, float* squared_distance) const {
  int best = -1;
  float best_d2 = max_distance * max_distance;
  for_each_candidate(q, max_distance, [&](int i) {
    const float d2 = (points_[i] - q).squaredNorm();
    if (d2 < best_d2 || (d2 == best_d2 && (best < 0 || i < best))) {
      best_d2 = d2;
      best = i;
    }
  });
  if (best >= 0 && squared_distance != nullptr) *squared_distance = best_d2;
  return best;
}

void SpatialHash::radius_search(const Eigen::Vector3f& q, float radius, std::vector<int>& out) const {
  const std::size_t first = out.size();
  const float r2 = radius * radius;
  for_each_candidate(q, radius, [&](int i) {
    if ((points_[i] - q).squaredNorm() <= r2) out.push_back(i);
  });
  std::sort(out.begin() + static_cast<std::ptrdiff_t>(first), out.end());
}

}  // namespace mfot
