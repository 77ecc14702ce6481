#include "mfot/part_boundary.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <stdexcept>
#include <string>
#include <utility>

#include "mfot/point_scatter.hpp"

namespace mfot {
namespace {

// Trilinear cells of one colour: the 8 bins around it and their weights (summing to 1).
struct Corners {
  std::array<int, 8> bin{};
  std::array<float, 8> weight{};
};

template <int Levels>
Corners corners_of(Rgb8 color) {
  int lo[3];
  float frac[3];
  const float channel[3] = {static_cast<float>(color.r), static_cast<float>(color.g), static_cast<float>(color.b)};
  for (int c = 0; c < 3; ++c) {
    // Bin k's centre is at (k + 0.5) * 256 / Levels.
    const float x = std::clamp(channel[c] * (Levels / 256.f) - 0.5f, 0.f, static_cast<float>(Levels - 1));
    lo[c] = std::min(static_cast<int>(x), Levels - 2);
    frac[c] = x - static_cast<float>(lo[c]);
  }
  Corners out;
  for (int k = 0; k < 8; ++k) {
    int bin = 0;
    float weight = 1.f;
    for (int c = 0; c < 3; ++c) {
      const int step = (k >> c) & 1;
      bin = bin * Levels + lo[c] + step;
      weight *= step ? frac[c] : 1.f - frac[c];
    }
    out.bin[static_cast<std::size_t>(k)] = bin;
    out.weight[static_cast<std::size_t>(k)] = weight;
  }
  return out;
}

}  // namespace

void PartBoundaryOptions::validate() const {
  if (!(radius >= 0.f && radius <= 0.2f)) {
    throw std::invalid_argument("PartBoundaryOptions.radius must be in [0, 0.2] m, got " + std::to_string(radius));
  }
  if (!(min_color_ratio > 1.f && std::isfinite(min_color_ratio))) {
    throw std::invalid_argument("PartBoundaryOptions.min_color_ratio must be finite and > 1, got " +
                                std::to_string(min_color_ratio));
  }
}

PartBoundaryRefiner::PartBoundaryRefiner(const PartBoundaryOptions& options)
    : options_((options.validate(), options)), hash_(options.radius > 0.f ? options.radius / 3.f : 1.f) {}

void PartBoundaryRefiner::add_vote(Histogram& histogram, Rgb8 color) {
  const Corners c = corners_of<kLevels>(color);
  for (std::size_t k = 0; k < 8; ++k) histogram[static_cast<std::size_t>(c.bin[k])] += c.weight[k];
}

float PartBoundaryRefiner::log_density(const Histogram& histogram, float votes, Rgb8 color) {
  const Corners c = corners_of<kLevels>(color);
  float value = 0.f;
  for (std::size_t k = 0; k < 8; ++k) value += c.weight[k] * histogram[static_cast<std::size_t>(c.bin[k])];
  return std::log((value + 1.f) / (votes + static_cast<float>(histogram.size())));
}

template <class LogDensity>
bool PartBoundaryRefiner::patch_prefers(std::size_t i, const std::vector<int>& part_of_point, std::size_t parts,
                                        LogDensity&& log_density_of) const {
  const auto own = static_cast<std::size_t>(part_of_point[i]);
  float ratio = 0.f;
  int scored = 0;
  for (int k = patch_offsets_[i]; k < patch_offsets_[i + 1]; ++k) {
    const auto j = static_cast<std::size_t>(patch_points_[static_cast<std::size_t>(k)]);
    if (static_cast<std::size_t>(part_of_point[j]) != own) continue;
    ratio += log_density_of(j) - log_density_[j * parts + own];
    ++scored;
  }
  return ratio >= std::log(options_.min_color_ratio) * static_cast<float>(scored);
}

void PartBoundaryRefiner::find_borders(std::span<const Eigen::Vector3f> positions,
                                       const std::vector<int>& part_of_point) {
  const std::size_t n = positions.size();
  constexpr float kFar = std::numeric_limits<float>::infinity();
  seam_distance_.assign(n, kFar);
  facing_.assign(n, -1);
  using Entry = std::pair<float, int>;  // (distance to the seam, point)
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
  for (std::size_t i = 0; i < n; ++i) {
    // A seam point faces the other part with the most points in its patch (the lower part of equals).
    int best = -1, best_count = 0;
    for (int k = patch_offsets_[i]; k < patch_offsets_[i + 1]; ++k) {
      const int part = part_of_point[static_cast<std::size_t>(patch_points_[static_cast<std::size_t>(k)])];
      if (part == part_of_point[i] || part == best) continue;
      int count = 0;
      for (int m = patch_offsets_[i]; m < patch_offsets_[i + 1]; ++m) {
        count += part_of_point[static_cast<std::size_t>(patch_points_[static_cast<std::size_t>(m)])] == part ? 1 : 0;
      }
      if (count > best_count || (count == best_count && part < best)) {
        best = part;
        best_count = count;
      }
    }
    if (best < 0) continue;
    seam_distance_[i] = 0.f;
    facing_[i] = best;
    queue.emplace(0.f, static_cast<int>(i));
  }
  // Dijkstra along the patches, within a part: every point takes the part its nearest seam faces.
  while (!queue.empty()) {
    const auto [distance, i] = queue.top();
    queue.pop();
    const auto ui = static_cast<std::size_t>(i);
    if (distance > seam_distance_[ui]) continue;
    for (int k = patch_offsets_[ui]; k < patch_offsets_[ui + 1]; ++k) {
      const auto j = static_cast<std::size_t>(patch_points_[static_cast<std::size_t>(k)]);
      if (part_of_point[j] != part_of_point[ui]) continue;
      const float through = distance + (positions[j] - positions[ui]).norm();
      if (through > options_.radius || through >= seam_distance_[j]) continue;
      seam_distance_[j] = through;
      facing_[j] = facing_[ui];
      queue.emplace(through, static_cast<int>(j));
    }
  }
}

bool PartBoundaryRefiner::continues_face_of(std::span<const Eigen::Vector3f> positions, std::span<const Rgb8> colors,
                                            const std::vector<int>& part_of_point, std::size_t parts, std::size_t i,
                                            int part) {
  // The plane of the point's patch (all parts).
  PointScatter patch;
  for (int k = patch_offsets_[i]; k < patch_offsets_[i + 1]; ++k) {
    patch.add(positions[static_cast<std::size_t>(patch_points_[static_cast<std::size_t>(k)])]);
  }
  if (patch.count() < 3) return false;
  const Eigen::Vector3f normal = patch.least_spread_direction().cast<float>();
  // Most of the part's points within radius lie on that plane: the point continues one of its faces.
  neighbours_.clear();
  hash_.radius_search(positions[i], options_.radius, neighbours_);
  const float tolerance = options_.radius / 6.f;
  local_model_.fill(0.f);
  int near = 0, on_plane = 0;
  for (const int j : neighbours_) {
    const auto uj = static_cast<std::size_t>(j);
    if (part_of_point[uj] != part) continue;
    ++near;
    if (std::abs(normal.dot(positions[uj] - positions[i])) > tolerance) continue;
    ++on_plane;
    add_vote(local_model_, colors[uj]);
  }
  if (near == 0 || 2 * on_plane < near) return false;
  // And that face's colours explain the patch min_color_ratio times better than the point's own
  // part does (a white face flush with a yellow end face says no, whatever colours the part has
  // elsewhere). One pseudo-count per bin, as in the parts' models: a face of a few points is weak
  // evidence, so a point far from the face waits for a later pass.
  const auto under_face = [&](std::size_t j) {
    return log_density(local_model_, static_cast<float>(on_plane), colors[j]);
  };
  return patch_prefers(i, part_of_point, parts, under_face);
}

std::size_t PartBoundaryRefiner::refine(std::span<const Eigen::Vector3f> positions, std::span<const Rgb8> colors,
                                        std::vector<int>& part_of_point) {
  const std::size_t n = positions.size();
  if (colors.size() != n || part_of_point.size() != n) {
    throw std::invalid_argument("PartBoundaryRefiner::refine: positions, colors and part_of_point differ in length");
  }
  const int parts = n == 0 ? 0 : *std::max_element(part_of_point.begin(), part_of_point.end()) + 1;
  if (options_.radius <= 0.f || parts < 2) return 0;
  const auto part_count = static_cast<std::size_t>(parts);

  // 1. patches
  hash_.build(positions);
  patch_offsets_.assign(1, 0);
  patch_points_.clear();
  for (std::size_t i = 0; i < n; ++i) {
    hash_.radius_search(positions[i], options_.radius / 3.f, patch_points_);
    patch_offsets_.push_back(static_cast<int>(patch_points_.size()));
  }

  // 2-3. borders, and colour models of the parts' cores
  find_borders(positions, part_of_point);
  std::vector<std::size_t> size(part_count, 0), core(part_count, 0);
  for (std::size_t i = 0; i < n; ++i) {
    ++size[static_cast<std::size_t>(part_of_point[i])];
    if (facing_[i] < 0) ++core[static_cast<std::size_t>(part_of_point[i])];
  }
  std::vector<Histogram> models(part_count, Histogram{});
  std::vector<float> votes(part_count, 0.f);
  for (std::size_t i = 0; i < n; ++i) {
    const auto p = static_cast<std::size_t>(part_of_point[i]);
    if (facing_[i] >= 0 && 2 * core[p] >= size[p]) continue;
    add_vote(models[p], colors[i]);
    votes[p] += 1.f;
  }
  log_density_.resize(n * part_count);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t p = 0; p < part_count; ++p) {
      log_density_[i * part_count + p] = log_density(models[p], votes[p], colors[i]);
    }
  }

  // 4-5. moves, pass by pass
  const std::vector<int> before = part_of_point;
  for (int pass = 0; pass < kMaxPasses; ++pass) {
    if (pass > 0) find_borders(positions, part_of_point);
    next_ = part_of_point;
    bool any = false;
    for (std::size_t i = 0; i < n; ++i) {
      if (facing_[i] < 0) continue;
      const auto other = static_cast<std::size_t>(facing_[i]);
      const auto under_other = [&](std::size_t j) { return log_density_[j * part_count + other]; };
      if (patch_prefers(i, part_of_point, part_count, under_other) &&
          continues_face_of(positions, colors, part_of_point, part_count, i, facing_[i])) {
        next_[i] = facing_[i];
        any = true;
      }
    }
    part_of_point.swap(next_);
    if (!any) break;
  }
  std::size_t moved = 0;
  for (std::size_t i = 0; i < n; ++i) moved += before[i] != part_of_point[i] ? 1 : 0;
  return moved;
}

}  // namespace mfot
