// Labels propagated through a cluster (steps in the header).

#include "mfot/label_propagation.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace mfot {

namespace {

float validated_radius(float radius, float min_seed_share) {
  if (!(radius >= 0.f && radius <= 0.1f)) {
    throw std::invalid_argument("LabelPropagation: radius must be in [0, 0.1] m, got " + std::to_string(radius));
  }
  if (!(min_seed_share >= 0.f && min_seed_share <= 1.f)) {
    throw std::invalid_argument("LabelPropagation: min_seed_share must be in [0, 1], got " +
                                std::to_string(min_seed_share));
  }
  return radius;
}

}  // namespace

LabelPropagation::LabelPropagation(float radius, float min_seed_share)
    : radius_(validated_radius(radius, min_seed_share)),
      min_seed_share_(min_seed_share),
      wave_hash_(std::max(radius, 1e-3f)) {}

void LabelPropagation::propagate(std::span<const Eigen::Vector3f> positions, std::span<const int> cluster_points,
                                 std::span<std::int32_t> labels, std::map<std::int32_t, std::vector<int>>& gained) {
  gained.clear();
  if (radius_ <= 0.f) return;
  // 1. labelled and unexplained
  free_.clear();
  wave_.clear();
  for (const int i : cluster_points) (labels[static_cast<std::size_t>(i)] == 0 ? free_ : wave_).push_back(i);
  // 2. seeded too thinly, or nothing to do
  if (free_.empty() || wave_.empty()) return;
  if (static_cast<float>(wave_.size()) < min_seed_share_ * static_cast<float>(cluster_points.size())) return;
  // 3. waves
  while (!wave_.empty() && !free_.empty()) {
    wave_points_.clear();
    for (const int i : wave_) wave_points_.push_back(positions[static_cast<std::size_t>(i)]);
    wave_hash_.build(wave_points_);
    next_wave_.clear();
    std::size_t kept = 0;
    for (const int i : free_) {
      const int nearest = wave_hash_.nearest(positions[static_cast<std::size_t>(i)], radius_);
      if (nearest < 0) {
        free_[kept++] = i;
        continue;
      }
      next_wave_.push_back(i);
      wave_labels_.push_back(labels[static_cast<std::size_t>(wave_[static_cast<std::size_t>(nearest)])]);
    }
    // Labels are set after the wave's queries so every point of a wave sees the same wave.
    for (std::size_t k = 0; k < next_wave_.size(); ++k) {
      labels[static_cast<std::size_t>(next_wave_[k])] = wave_labels_[k];
      gained[wave_labels_[k]].push_back(next_wave_[k]);
    }
    wave_labels_.clear();
    free_.resize(kept);
    std::swap(wave_, next_wave_);
  }
}

}  // namespace mfot
