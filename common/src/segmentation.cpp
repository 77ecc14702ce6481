#include "mfot/segmentation.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace mfot {

void SegmentationOptions::validate() const {
  if (!(tau > 0.f && tau <= 1.f)) {
    throw std::invalid_argument("SegmentationOptions.tau must be in (0, 1] metres, got " + std::to_string(tau));
  }
}

namespace {
const SegmentationOptions& validated(const SegmentationOptions& options) {
  options.validate();
  return options;
}
}  // namespace

Segmenter::Segmenter(const SegmentationOptions& options) : options_(validated(options)), hash_(options.tau) {}

void Segmenter::segment(std::span<const Eigen::Vector3f> scene_points, std::span<const SegmentationObject> objects,
                        SegmentationResult& result, ThreadPool* pool) {
  result.object_ids.clear();
  result.counts.assign(objects.size(), 0);
  std::size_t total_model_points = 0;
  for (const auto& object : objects) {
    if (object.id <= 0) {
      throw std::invalid_argument("Segmenter: object id must be > 0, got " + std::to_string(object.id));
    }
    for (const std::int32_t seen : result.object_ids) {
      if (seen == object.id) throw std::invalid_argument("Segmenter: repeated object id " + std::to_string(object.id));
    }
    result.object_ids.push_back(object.id);
    total_model_points += object.model_points.size();
  }

  model_points_camera_.resize(total_model_points);
  owner_.resize(total_model_points);
  std::size_t next = 0;
  for (std::size_t k = 0; k < objects.size(); ++k) {
    Pose pose = objects[k].pose;
    pose.rotation.normalize();
    const Eigen::Isometry3f to_camera = pose.isometry();
    for (const auto& p : objects[k].model_points) {
      model_points_camera_[next] = to_camera * p;
      owner_[next] = static_cast<std::int32_t>(k);
      ++next;
    }
  }
  // Model points are listed object by object, so the hash's lower-index tie rule favours the
  // object listed first.
  hash_.build(model_points_camera_);

  // Each point's object index + 1 (0: none), then its id and the counts in one pass.
  result.labels.resize(scene_points.size());
  const auto label_range = [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      // Most scene points lie within tau / 2 of their model: looked for there first.
      const int nearest = hash_.nearest_near_first(scene_points[i], options_.tau);
      result.labels[i] = nearest < 0 ? 0 : owner_[static_cast<std::size_t>(nearest)] + 1;
    }
  };
  const std::size_t n = scene_points.size();
  const std::size_t ranges = pool != nullptr && pool->threads() > 1 ? 4 * static_cast<std::size_t>(pool->threads()) : 1;
  if (ranges == 1) {
    label_range(0, n);
  } else {
    pool->run(ranges, [&](std::size_t r) { label_range(r * n / ranges, (r + 1) * n / ranges); });
  }
  for (std::int32_t& label : result.labels) {
    if (label == 0) continue;
    const auto k = static_cast<std::size_t>(label - 1);
    label = result.object_ids[k];
    ++result.counts[k];
  }
}

void gather_segment(const ColoredCloud& scene, std::span<const std::int32_t> labels, std::int32_t id,
                    ColoredCloud& out) {
  if (labels.size() != scene.size() || scene.colors.size() != scene.positions.size()) {
    throw std::invalid_argument("gather_segment: labels, scene positions and colours must have one size");
  }
  out.clear();
  for (std::size_t i = 0; i < labels.size(); ++i) {
    if (labels[i] == id) out.push_back(scene.positions[i], scene.colors[i]);
  }
}

}  // namespace mfot
