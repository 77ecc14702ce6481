// Re-identification's memory (contract in the header).

#include "mfot/reidentification.hpp"

#include <algorithm>
#include <cmath>

namespace mfot {

ColorHistogram color_histogram(const ObjectModel& model) {
  ColorHistogram histogram{};
  float total = 0.f;
  for (const SmrFeature& f : model.features) {
    histogram[f.hue_bin] += f.hue_weight_lo;
    histogram[(f.hue_bin + 1) % 6] += f.hue_weight_hi;
    histogram[f.gray_bin] += f.gray_weight;
    total += f.hue_weight_lo + f.hue_weight_hi + f.gray_weight;
  }
  if (total > 0.f) {
    for (float& h : histogram) h /= total;
  }
  return histogram;
}

float color_similarity(const ColorHistogram& a, const ColorHistogram& b) {
  float coefficient = 0.f;  // Bhattacharyya
  for (int k = 0; k < kSmrBins; ++k) coefficient += std::sqrt(a[k] * b[k]);
  return coefficient;
}

float model_radius(const ObjectModel& model) {
  if (model.cloud.empty()) return 0.f;
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
  for (const Eigen::Vector3f& p : model.cloud.positions) centroid += p;
  centroid /= static_cast<float>(model.cloud.size());
  float radius = 0.f;
  for (const Eigen::Vector3f& p : model.cloud.positions) radius = std::max(radius, (p - centroid).norm());
  return radius;
}

namespace {

// The better of the two views' similarities: an object grown while entering (a hand and its arm) may come back
// showing only what it showed first.
float best_view_similarity(const ColorHistogram& histogram, const ColorHistogram& last, const ColorHistogram& first) {
  return std::max(color_similarity(histogram, last), color_similarity(histogram, first));
}

}  // namespace

void RetiredObjects::expire(std::int64_t frame, int frames) {
  std::erase_if(retired_, [&](const auto& entry) { return frame - entry.second.retired_frame >= frames; });
}

std::int32_t RetiredObjects::match(const ColorHistogram& histogram, std::int64_t retired_by) const {
  std::int32_t best = 0;
  float best_similarity = similarity_;
  for (const auto& [id, retired] : retired_) {  // ascending ids: ties keep the oldest
    if (retired.retired_frame > retired_by) continue;
    const float similarity = best_view_similarity(histogram, retired.histogram, retired.first_seen);
    if (similarity > best_similarity || (best == 0 && similarity >= best_similarity)) {
      best = id;
      best_similarity = similarity;
    }
  }
  return best;
}

std::int32_t RetiredObjects::match_unseen(std::span<const UnseenObject> unseen, const ColorHistogram& histogram,
                                          float radius, float max_radius_ratio) const {
  std::int32_t best = 0;
  float best_similarity = similarity_;
  for (const UnseenObject& object : unseen) {
    if (radius > max_radius_ratio * object.radius) continue;
    const float similarity = best_view_similarity(histogram, object.histogram, object.first_seen);
    if (similarity > best_similarity || (best == 0 && similarity >= best_similarity) ||
        (similarity == best_similarity && object.id < best)) {
      best = object.id;
      best_similarity = similarity;
    }
  }
  return best;
}

}  // namespace mfot
