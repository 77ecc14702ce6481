#include "mfot/object_manager.hpp"

#include "mfot/particle_filter.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace mfot {

void ObjectManagerOptions::validate() const {
  segmentation.validate();
  model_update.validate();
  new_objects.validate();
  support.validate();
  if (min_object_points < 1) throw std::invalid_argument("ObjectManagerOptions.min_object_points must be >= 1");
  if (growth_frames < 0) throw std::invalid_argument("ObjectManagerOptions.growth_frames must be >= 0");
  if (max_model_points < min_object_points) {
    throw std::invalid_argument("ObjectManagerOptions.max_model_points must be >= min_object_points (" +
                                std::to_string(min_object_points) + ")");
  }
}

ObjectManager::ObjectManager(const ObjectManagerOptions& options)
    : options_((options.validate(), options)),
      segmenter_(options.segmentation),
      detector_(options.new_objects),
      support_(options.support) {}

const ObjectManagerFrame& ObjectManager::process(const ColoredCloud& scene,
                                                 std::span<const std::int32_t> cluster_of_point,
                                                 const std::map<std::int32_t, ObjectEstimate>& estimates) {
  if (cluster_of_point.size() != scene.size()) {
    throw std::invalid_argument("ObjectManager::process: cluster_of_point has " +
                                std::to_string(cluster_of_point.size()) + " entries for " +
                                std::to_string(scene.size()) + " scene points");
  }
  frame_.created.clear();
  frame_.retired.clear();

  // 1. estimates
  for (auto& [id, object] : objects_) {
    const auto it = estimates.find(id);
    if (it == estimates.end()) {
      object.stale = true;
      continue;
    }
    object.velocity = pose_difference(object.pose, it->second.pose);
    object.pose = it->second.pose;
    object.confidence = it->second.confidence;
    object.stale = false;
  }

  // 2. segmentation (3.22, 3.23)
  seg_objects_.clear();
  for (const auto& [id, object] : objects_) {
    seg_objects_.push_back({id, object.model.cloud.positions, object.pose});
  }
  segmenter_.segment(scene.positions, seg_objects_, segmentation_);
  frame_.labels = segmentation_.labels;

  // 3. model update (3.4)
  for (std::size_t k = 0; k < segmentation_.object_ids.size(); ++k) {
    ManagedObject& object = objects_.at(segmentation_.object_ids[k]);
    object.support = segmentation_.counts[k];
    if (object.stale || object.support == 0 || options_.model_update.alpha <= 0.f) continue;
    object.model = updaters_.at(object.id)->update(object.model, scene, segmentation_.labels, object.id, object.pose);
    ++object.version;
  }

  // 4. retire objects without support
  support_.update(segmentation_.object_ids, segmentation_.counts, frame_.retired);
  for (const std::int32_t id : frame_.retired) {
    objects_.erase(id);
    updaters_.erase(id);
  }

  // 5. new objects from clusters no object explains
  clusters_.point_indices.clear();
  clusters_.offsets.assign(1, 0);
  clusters_.cluster_of_point.assign(cluster_of_point.begin(), cluster_of_point.end());
  std::int32_t num_clusters = 0;
  for (const std::int32_t c : cluster_of_point) num_clusters = std::max(num_clusters, c + 1);
  {
    std::vector<int> sizes(static_cast<std::size_t>(num_clusters), 0);
    for (const std::int32_t c : cluster_of_point) {
      if (c >= 0) ++sizes[static_cast<std::size_t>(c)];
    }
    for (const int s : sizes) clusters_.offsets.push_back(clusters_.offsets.back() + s);
    clusters_.point_indices.resize(static_cast<std::size_t>(clusters_.offsets.back()));
    std::vector<int> fill(clusters_.offsets.begin(), clusters_.offsets.end() - 1);
    for (std::size_t i = 0; i < cluster_of_point.size(); ++i) {
      const std::int32_t c = cluster_of_point[i];
      if (c >= 0) clusters_.point_indices[static_cast<std::size_t>(fill[static_cast<std::size_t>(c)]++)] = static_cast<int>(i);
    }
  }
  if (frames_ == 0 && objects_.empty()) {
    for (std::size_t c = 0; c < clusters_.size(); ++c) create_object(scene, clusters_.cluster(c));
  } else {
    for (std::size_t c = 0; c < clusters_.size(); ++c) grow_young_object(scene, clusters_.cluster(c));
    detector_.update(scene.positions, clusters_, frame_.labels, confirmed_);
    for (const int c : confirmed_) create_object(scene, clusters_.cluster(static_cast<std::size_t>(c)));
  }
  ++frames_;
  return frame_;
}

bool ObjectManager::grow_young_object(const ColoredCloud& scene, std::span<const int> cluster_points) {
  if (options_.growth_frames == 0) return false;
  std::int32_t owner = 0;
  std::size_t free_count = 0;
  for (const int i : cluster_points) {
    const std::int32_t label = frame_.labels[static_cast<std::size_t>(i)];
    if (label == 0) {
      ++free_count;
    } else if (owner == 0) {
      owner = label;
    } else if (label != owner) {
      return false;  // the cluster joins several objects (contact): never guess
    }
  }
  if (owner == 0 || free_count < options_.min_object_points ||
      static_cast<float>(free_count) <= options_.new_objects.min_unassigned_share * static_cast<float>(cluster_points.size())) {
    return false;
  }
  ManagedObject& object = objects_.at(owner);
  if (frames_ - object.created_frame >= options_.growth_frames) return false;
  const Eigen::Isometry3f camera_to_object = object.pose.isometry().inverse();
  const std::size_t room = options_.max_model_points > object.model.cloud.size()
                               ? options_.max_model_points - object.model.cloud.size()
                               : 0;
  const std::size_t take = std::min(room, free_count);
  std::size_t seen = 0;
  std::size_t taken = 0;
  std::vector<Rgb8> added_colors;
  for (const int i : cluster_points) {
    const auto k = static_cast<std::size_t>(i);
    if (frame_.labels[k] != 0) continue;
    frame_.labels[k] = owner;
    // Deterministic even subsampling of the free points into the room left in the model.
    if (taken < take && seen * take >= taken * free_count) {
      object.model.cloud.push_back(camera_to_object * scene.positions[k], scene.colors[k]);
      added_colors.push_back(scene.colors[k]);
      ++taken;
    }
    ++seen;
  }
  const auto features = compute_smr(added_colors, options_.smr);
  object.model.features.insert(object.model.features.end(), features.begin(), features.end());
  object.support += free_count;
  ++object.version;
  return true;
}

void ObjectManager::create_object(const ColoredCloud& scene, std::span<const int> cluster_points) {
  // Only the cluster's points that no object explains form the new model.
  std::vector<int> free_points;
  for (const int i : cluster_points) {
    if (frame_.labels[static_cast<std::size_t>(i)] == 0) free_points.push_back(i);
  }
  if (free_points.size() < options_.min_object_points) return;
  const std::size_t n = std::min(free_points.size(), options_.max_model_points);
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
  for (const int i : free_points) centroid += scene.positions[static_cast<std::size_t>(i)];
  centroid /= static_cast<float>(free_points.size());

  ManagedObject object;
  object.id = next_id_++;
  object.pose.translation = centroid;
  object.model.cloud.reserve(n);
  // Deterministic even subsampling keeps the model spread over the whole cluster.
  for (std::size_t k = 0; k < n; ++k) {
    const auto i = static_cast<std::size_t>(free_points[k * free_points.size() / n]);
    object.model.cloud.push_back(scene.positions[i] - centroid, scene.colors[i]);
  }
  object.model.features = compute_smr(object.model.cloud.colors, options_.smr);
  object.support = free_points.size();
  object.confidence = 1.f;
  object.created_frame = frames_;
  for (const int i : free_points) frame_.labels[static_cast<std::size_t>(i)] = object.id;

  ModelUpdateOptions update = options_.model_update;
  update.seed = options_.model_update.seed + static_cast<std::uint64_t>(object.id);
  updaters_.emplace(object.id, std::make_unique<ModelUpdater>(update));
  frame_.created.push_back(object.id);
  objects_.emplace(object.id, std::move(object));
}

}  // namespace mfot
