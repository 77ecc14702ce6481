#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "mfot/preprocessing.hpp"

namespace mfot {

namespace {

// Voxel coordinates are clamped to 21 signed bits so three pack into one 64-bit key (+-5 km
// at 5 mm). Clamping only merges voxels far outside any workspace.
constexpr int kCoordBits = 21;
constexpr float kCoordMin = -static_cast<float>(1 << (kCoordBits - 1));
constexpr float kCoordMax = static_cast<float>((1 << (kCoordBits - 1)) - 1);

std::uint64_t packed_coord(float scaled) {
  constexpr std::uint64_t offset = std::uint64_t{1} << (kCoordBits - 1);
  const int c = static_cast<int>(std::clamp(std::floor(scaled), kCoordMin, kCoordMax));
  return static_cast<std::uint64_t>(static_cast<std::int64_t>(c) + static_cast<std::int64_t>(offset));
}

std::size_t slot_hash(std::uint64_t key) {
  std::uint64_t h = key * 0x9E3779B97F4A7C15ull;
  h ^= h >> 29;
  return static_cast<std::size_t>(h);
}

}  // namespace

VoxelDownsampler::VoxelDownsampler(float leaf_size) : leaf_size_(leaf_size), inv_leaf_(0.f) {
  if (!std::isfinite(leaf_size) || !(leaf_size > 0.f) || leaf_size > 1.f) {
    throw std::invalid_argument("VoxelDownsampler: leaf_size must be in (0, 1] metres, got " +
                                std::to_string(leaf_size));
  }
  inv_leaf_ = 1.f / leaf_size;
}

void VoxelDownsampler::set_grid_origin(const Eigen::Vector3f& origin) {
  if (!origin.allFinite()) throw std::invalid_argument("VoxelDownsampler: the grid origin must be finite");
  grid_origin_ = origin;
}

std::uint64_t VoxelDownsampler::key_of(const Eigen::Vector3f& p) const {
  const Eigen::Vector3f scaled = (p - grid_origin_) * inv_leaf_;
  return packed_coord(scaled.x()) | (packed_coord(scaled.y()) << kCoordBits) |
         (packed_coord(scaled.z()) << (2 * kCoordBits));
}

int VoxelDownsampler::find_or_insert(std::uint64_t key, std::uint32_t source_id) {
  std::size_t slot = slot_hash(key) & slot_mask_;
  while (slot_stamps_[slot] == generation_) {
    if (slot_keys_[slot] == key) return slot_voxels_[slot];
    slot = (slot + 1) & slot_mask_;
  }
  const int voxel = static_cast<int>(sums_.size());
  slot_stamps_[slot] = generation_;
  slot_keys_[slot] = key;
  slot_voxels_[slot] = voxel;
  sums_.emplace_back(Eigen::Vector3f::Zero());
  color_sums_.emplace_back(Eigen::Vector3i::Zero());
  first_source_.push_back(source_id);
  counts_.push_back(0);
  return voxel;
}

std::size_t VoxelDownsampler::downsample(std::span<const Eigen::Vector3f> positions, std::span<const Rgb8> colors,
                                         std::span<const std::uint32_t> source_ids, ThreadPool* pool) {
  if (colors.size() != positions.size() || source_ids.size() != positions.size()) {
    throw std::invalid_argument("VoxelDownsampler::downsample: colors and source_ids must have the positions' length");
  }
  const std::size_t n = positions.size();

  // At most n voxels; keep the table at most half full.
  std::size_t capacity = std::max<std::size_t>(slot_keys_.size(), 64);
  while (capacity < 2 * n) capacity *= 2;
  if (capacity != slot_keys_.size()) {
    slot_keys_.assign(capacity, 0);
    slot_voxels_.assign(capacity, -1);
    slot_stamps_.assign(capacity, 0);
    generation_ = 0;
  }
  slot_mask_ = capacity - 1;
  if (++generation_ == 0) {
    std::fill(slot_stamps_.begin(), slot_stamps_.end(), 0u);
    generation_ = 1;
  }

  sums_.clear();
  color_sums_.clear();
  first_source_.clear();
  counts_.clear();
  voxel_of_input_.resize(n);

  // Keys are independent per point; voxel numbering (first met in input order) and the sums (in
  // input order, so the floating-point result is fixed) stay on this thread.
  input_keys_.resize(n);
  const std::size_t pieces =
      pool == nullptr || pool->threads() == 1
          ? 1
          : std::clamp<std::size_t>(n / kMinPreprocessPointsPerPiece, 1,
                                    kPreprocessPiecesPerThread * static_cast<std::size_t>(pool->threads()));
  const auto compute_keys = [this, positions, n, pieces](std::size_t p) {
    for (std::size_t i = n * p / pieces; i < n * (p + 1) / pieces; ++i) input_keys_[i] = key_of(positions[i]);
  };
  if (pieces > 1) {
    pool->run(pieces, compute_keys);
  } else {
    compute_keys(0);
  }

  // Raster-ordered input visits each voxel in runs of neighbouring pixels: the previous key
  // saves most table probes.
  std::uint64_t previous_key = ~std::uint64_t{0};
  int previous_voxel = -1;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f& p = positions[i];
    const std::uint64_t key = input_keys_[i];
    if (key != previous_key) {
      previous_key = key;
      previous_voxel = find_or_insert(key, source_ids[i]);
    }
    const int voxel = previous_voxel;
    voxel_of_input_[i] = voxel;
    sums_[voxel] += p;
    color_sums_[voxel] += Eigen::Vector3i(colors[i].r, colors[i].g, colors[i].b);
    ++counts_[voxel];
  }

  const std::size_t voxels = sums_.size();
  mean_positions_.resize(voxels);
  mean_colors_.resize(voxels);
  for (std::size_t k = 0; k < voxels; ++k) {
    const int count = counts_[k];
    mean_positions_[k] = sums_[k] / static_cast<float>(count);
    const Eigen::Vector3i rounded = (color_sums_[k].array() + count / 2) / count;
    mean_colors_[k] = Rgb8{static_cast<std::uint8_t>(rounded[0]), static_cast<std::uint8_t>(rounded[1]),
                           static_cast<std::uint8_t>(rounded[2])};
  }
  return voxels;
}

int VoxelDownsampler::voxel_index_of(const Eigen::Vector3f& p) const {
  if (slot_keys_.empty() || !std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.z())) return -1;
  const std::uint64_t key = key_of(p);
  std::size_t slot = slot_hash(key) & slot_mask_;
  while (slot_stamps_[slot] == generation_) {
    if (slot_keys_[slot] == key) return slot_voxels_[slot];
    slot = (slot + 1) & slot_mask_;
  }
  return -1;
}

}  // namespace mfot
