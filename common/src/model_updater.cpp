#include "mfot/model_updater.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace mfot {

namespace {

// Unbiased integer in [0, n) from raw 64-bit draws (rejection of the short top range), so the
// draws are identical on every standard library.
std::uint64_t uniform_below(std::mt19937_64& rng, std::uint64_t n) {
  const std::uint64_t reject_below = (0 - n) % n;  // 2^64 mod n
  std::uint64_t x = rng();
  while (x < reject_below) x = rng();
  return x % n;
}

void check_model(const ObjectModel& model) {
  if (model.cloud.colors.size() != model.cloud.positions.size() ||
      model.features.size() != model.cloud.positions.size()) {
    throw std::invalid_argument("ModelUpdater: the old model's positions, colours and features must have one size");
  }
}

void check_cloud(const ColoredCloud& cloud, const char* what) {
  if (cloud.colors.size() != cloud.positions.size()) {
    throw std::invalid_argument(std::string("ModelUpdater: ") + what + " positions and colours must have one size");
  }
}

const ModelUpdateOptions& validated(const ModelUpdateOptions& options) {
  options.validate();
  return options;
}

}  // namespace

void ModelUpdateOptions::validate() const {
  if (!(alpha >= 0.f && alpha <= 1.f)) {
    throw std::invalid_argument("ModelUpdateOptions.alpha must be in [0, 1], got " + std::to_string(alpha));
  }
  if (!(seen_radius >= 0.f && seen_radius <= 0.1f)) {
    throw std::invalid_argument("ModelUpdateOptions.seen_radius must be in [0, 0.1] m, got " +
                                std::to_string(seen_radius));
  }
}

ModelUpdater::ModelUpdater(const ModelUpdateOptions& options)
    : options_(validated(options)), rng_(options.seed), seen_hash_(std::max(options.seen_radius, 1e-3f)) {}

ObjectModel ModelUpdater::update(const ObjectModel& old_model, const ColoredCloud& segmented, const Pose& estimate) {
  check_model(old_model);
  check_cloud(segmented, "segmented");
  new_candidates_.resize(segmented.size());
  for (std::size_t i = 0; i < segmented.size(); ++i) new_candidates_[i] = static_cast<int>(i);
  return mix(old_model, segmented, estimate);
}

ObjectModel ModelUpdater::update(const ObjectModel& old_model, const ColoredCloud& scene,
                                 std::span<const std::int32_t> labels, std::int32_t id, const Pose& estimate) {
  check_model(old_model);
  check_cloud(scene, "scene");
  if (labels.size() != scene.size()) throw std::invalid_argument("ModelUpdater: labels.size() must equal scene.size()");
  new_candidates_.clear();
  for (std::size_t i = 0; i < labels.size(); ++i) {
    if (labels[i] == id) new_candidates_.push_back(static_cast<int>(i));
  }
  return mix(old_model, scene, estimate);
}

void ModelUpdater::draw_without_replacement(std::vector<int>& candidates, std::size_t count) {
  if (count < candidates.size()) {
    for (std::size_t i = 0; i < count; ++i) {
      const std::size_t j = i + static_cast<std::size_t>(uniform_below(rng_, candidates.size() - i));
      std::swap(candidates[i], candidates[j]);
    }
  }
  // Sorted picks keep the old model's order and make the result independent of the draw order.
  std::sort(candidates.begin(), candidates.begin() + static_cast<std::ptrdiff_t>(count));
}

ObjectModel ModelUpdater::mix(const ObjectModel& old_model, const ColoredCloud& source, const Pose& estimate) {
  const std::size_t old_size = old_model.cloud.size();
  const std::size_t available = new_candidates_.size();
  const std::size_t target = options_.target_size > 0 ? options_.target_size : old_size;
  Pose pose = estimate;
  pose.rotation.normalize();
  const Eigen::Isometry3f to_object = pose.isometry().inverse();

  // Old points without a segmented point near them are unseen (occluded or out of view).
  old_candidates_.clear();
  unseen_.clear();
  if (options_.seen_radius > 0.f && options_.alpha > 0.f && available > 0) {
    segmented_in_object_.clear();
    for (const int i : new_candidates_)
      segmented_in_object_.push_back(to_object * source.positions[static_cast<std::size_t>(i)]);
    seen_hash_.build(segmented_in_object_);
    for (std::size_t i = 0; i < old_size; ++i) {
      const bool seen = seen_hash_.any_within(old_model.cloud.positions[i], options_.seen_radius);
      (seen ? old_candidates_ : unseen_).push_back(static_cast<int>(i));
    }
  } else {
    for (std::size_t i = 0; i < old_size; ++i) old_candidates_.push_back(static_cast<int>(i));
  }

  std::size_t n_new =
      std::min(static_cast<std::size_t>(std::llround(static_cast<double>(options_.alpha) * target)), available);
  if (!unseen_.empty() && target <= old_size) n_new = std::min(n_new, old_candidates_.size());
  std::size_t n_old = std::min(target - std::min(target, n_new), old_size);
  n_new = std::min(target - n_old, available);

  // Unseen points are kept first; the rest of n_old is drawn from the seen ones. A shrinking
  // model (target below the unseen count) draws over all old points.
  if (unseen_.size() > n_old) {
    old_candidates_.insert(old_candidates_.end(), unseen_.begin(), unseen_.end());
    unseen_.clear();
  }
  draw_without_replacement(old_candidates_, n_old - unseen_.size());
  old_candidates_.resize(n_old - unseen_.size());
  old_candidates_.insert(old_candidates_.end(), unseen_.begin(), unseen_.end());
  std::sort(old_candidates_.begin(), old_candidates_.end());
  draw_without_replacement(new_candidates_, n_new);

  ObjectModel model;
  model.cloud.reserve(n_old + n_new);
  model.features.reserve(n_old + n_new);
  for (std::size_t k = 0; k < n_old; ++k) {
    const auto i = static_cast<std::size_t>(old_candidates_[k]);
    model.cloud.push_back(old_model.cloud.positions[i], old_model.cloud.colors[i]);
    model.features.push_back(old_model.features[i]);
  }

  new_colors_.resize(n_new);
  for (std::size_t k = 0; k < n_new; ++k) {
    const auto i = static_cast<std::size_t>(new_candidates_[k]);
    model.cloud.push_back(to_object * source.positions[i], source.colors[i]);
    new_colors_[k] = source.colors[i];
  }
  const std::vector<SmrFeature> new_features = compute_smr(new_colors_, options_.smr);
  model.features.insert(model.features.end(), new_features.begin(), new_features.end());
  return model;
}

}  // namespace mfot
