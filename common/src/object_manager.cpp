#include "mfot/object_manager.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>
#include <string>

#include "mfot/hypothesis.hpp"
#include "mfot/model_parts.hpp"
#include "mfot/option_range.hpp"
#include "mfot/particle_filter.hpp"

namespace mfot {

void ObjectManagerOptions::validate() const {
  segmentation.validate();
  model_update.validate();
  new_objects.validate();
  support.validate();
  if (min_object_points < 1) throw std::invalid_argument("ObjectManagerOptions.min_object_points must be >= 1");
  if (growth_frames < 0) throw std::invalid_argument("ObjectManagerOptions.growth_frames must be >= 0");
  if (reidentify_frames < 0) throw std::invalid_argument("ObjectManagerOptions.reidentify_frames must be >= 0");
  if (!(reidentify_similarity > 0.f && reidentify_similarity <= 1.f)) {
    throw std::invalid_argument("ObjectManagerOptions.reidentify_similarity must be in (0, 1], got " +
                                std::to_string(reidentify_similarity));
  }
  if (!(reidentify_grown_min_share >= 0.f && reidentify_grown_min_share <= 1.f)) {
    throw std::invalid_argument("ObjectManagerOptions.reidentify_grown_min_share must be in [0, 1], got " +
                                std::to_string(reidentify_grown_min_share));
  }
  if (!(reidentify_unseen_radius_ratio == 0.f ||
        (reidentify_unseen_radius_ratio >= 1.f && reidentify_unseen_radius_ratio <= 10.f))) {
    throw std::invalid_argument("ObjectManagerOptions.reidentify_unseen_radius_ratio must be 0 or in [1, 10], got " +
                                std::to_string(reidentify_unseen_radius_ratio));
  }
  if (!(propagation_min_seed_share >= 0.f && propagation_min_seed_share <= 1.f)) {
    throw std::invalid_argument("ObjectManagerOptions.propagation_min_seed_share must be in [0, 1], got " +
                                std::to_string(propagation_min_seed_share));
  }
  if (!(propagation_radius >= 0.f && propagation_radius <= 0.1f)) {
    throw std::invalid_argument("ObjectManagerOptions.propagation_radius must be in [0, 0.1] m, got " +
                                std::to_string(propagation_radius));
  }
  if (!(held_birth_margin >= 0.f && held_birth_margin <= 0.5f)) {
    throw std::invalid_argument("ObjectManagerOptions.held_birth_margin must be in [0, 0.5] m, got " +
                                std::to_string(held_birth_margin));
  }
  if (entering_frames < 0 || entering_frames > 1000) {
    throw std::invalid_argument("ObjectManagerOptions.entering_frames must be in [0, 1000], got " +
                                std::to_string(entering_frames));
  }
  if (!(entering_distance > 0.f && entering_distance <= 0.1f)) {
    throw std::invalid_argument("ObjectManagerOptions.entering_distance must be in (0, 0.1] m, got " +
                                std::to_string(entering_distance));
  }
  if (!(hidden_occluded_share >= 0.f && hidden_occluded_share <= 1.f)) {
    throw std::invalid_argument("ObjectManagerOptions.hidden_occluded_share must be in [0, 1], got " +
                                std::to_string(hidden_occluded_share));
  }
  occlusion.validate();
  registration.validate();
  discovery.validate();
  join_split.validate();
  carry.validate();
  companion.validate();
  refit.validate("ObjectManagerOptions.refit");
  if (max_model_points < min_object_points) {
    throw std::invalid_argument("ObjectManagerOptions.max_model_points must be >= min_object_points (" +
                                std::to_string(min_object_points) + ")");
  }
}

namespace {
std::vector<std::unique_ptr<ObjectDiscovery>> one_or_none(std::unique_ptr<ObjectDiscovery> discovery) {
  std::vector<std::unique_ptr<ObjectDiscovery>> discoveries;
  if (discovery) discoveries.push_back(std::move(discovery));
  return discoveries;
}
}  // namespace

ObjectManager::ObjectManager(const ObjectManagerOptions& options, std::unique_ptr<ObjectDiscovery> discovery)
    : ObjectManager(options, one_or_none(std::move(discovery))) {}

ObjectManager::ObjectManager(const ObjectManagerOptions& options,
                             std::vector<std::unique_ptr<ObjectDiscovery>> discoveries)
    : options_((options.validate(), options)),
      pool_(std::max<int>(1, static_cast<int>(discoveries.size()))),
      parts_(std::move(discoveries), options.discovery.boundary, options.min_object_points, pool_),
      segmenter_(options.segmentation),
      detector_(options.new_objects),
      support_(options.support),
      occlusion_(options.occlusion),
      refit_(options.refit),
      retired_(options.reidentify_similarity),
      joiner_(options.join_split),
      splitter_(options.join_split, options.min_object_points),
      overlap_joiner_(options.join_split),
      confirmation_(options.discovery),
      carry_(options.carry),
      propagation_(options.propagation_radius, options.propagation_min_seed_share),
      registration_(std::make_unique<ModelRegistration>(options.registration)) {}

const ObjectManagerFrame& ObjectManager::process(const ColoredCloud& scene,
                                                 std::span<const std::int32_t> cluster_of_point, int standing_clusters,
                                                 const std::map<std::int32_t, ObjectEstimate>& estimates) {
  if (standing_clusters < 0) {
    throw std::invalid_argument("ObjectManager::process: standing_clusters " + std::to_string(standing_clusters) +
                                " is negative");
  }
  if (cluster_of_point.size() != scene.size()) {
    throw std::invalid_argument("ObjectManager::process: cluster_of_point has " +
                                std::to_string(cluster_of_point.size()) + " entries for " +
                                std::to_string(scene.size()) + " scene points");
  }
  if (scene.colors.size() != scene.size()) {
    throw std::invalid_argument("ObjectManager::process: the scene has " + std::to_string(scene.colors.size()) +
                                " colours for " + std::to_string(scene.size()) + " points");
  }
  // A non-finite point would become a non-finite model and pose (and a NaN spatial-hash key); a
  // cluster index beyond the point count would size the per-cluster tables below.
  for (std::size_t i = 0; i < scene.size(); ++i) {
    if (!scene.positions[i].allFinite()) {
      throw std::invalid_argument("ObjectManager::process: scene point " + std::to_string(i) + " is non-finite");
    }
    if (cluster_of_point[i] < -1 || static_cast<std::size_t>(cluster_of_point[i] + 1) > scene.size()) {
      throw std::invalid_argument("ObjectManager::process: cluster index " + std::to_string(cluster_of_point[i]) +
                                  " of point " + std::to_string(i) + " is outside [-1, " +
                                  std::to_string(scene.size()) + ")");
    }
  }
  frame_.created.clear();
  frame_.registered.clear();
  frame_.retired.clear();
  frame_.reidentified.clear();
  frame_.found_carried.clear();
  frame_.joined.clear();
  frame_.split.clear();
  frame_.regrouped.clear();
  gripped_away_.clear();
  grown_.clear();
  occlusion_scene_set_ = false;  // scene_occlusion() indexes this frame's scene once, when a step needs it

  // 1. estimates; hidden objects carried, companions chosen
  take_estimates(estimates);
  if (options_.carry.frames > 0) carry_hidden(scene);
  if (options_.companion.contact_distance > 0.f) choose_companions();
  // 2. segmentation (3.22, 3.23)
  segment(scene);
  // 3. model update (3.4); grown parts re-fitted on the first view
  update_models(scene);
  refit_parts(scene);
  // 4. retire objects without support, unless hidden; and those gripped away
  retire_unsupported(scene);
  // 5. labels propagated, young models grown; 6. new objects from clusters no object explains, re-identified
  index_clusters(cluster_of_point);
  standing_clusters_ = std::min(clusters_.size(), static_cast<std::size_t>(standing_clusters));
  propagate_and_create(scene);
  // 7. join parts that move as one, split objects whose parts moved apart, confirm the discovery
  join_and_split(scene, cluster_of_point);
  std::sort(frame_.created.begin(), frame_.created.end());  // a re-identified id may be older
  ++frames_;
  return frame_;
}

void ObjectManager::take_estimates(const std::map<std::int32_t, ObjectEstimate>& estimates) {
  for (auto& [id, object] : objects_) {
    object.carried_by = 0;
    object.held = false;
    const auto it = estimates.find(id);
    // A non-finite estimate (a diverged tracker) counts as none: the last pose is kept.
    if (it == estimates.end() || !it->second.pose.translation.allFinite() ||
        !it->second.pose.rotation.coeffs().allFinite() || !std::isfinite(it->second.confidence)) {
      object.stale = true;
      continue;
    }
    if (options_.carry.frames > 0 && it->second.held) tracked_.at(id).pose_before = object.pose;  // may be carried
    object.velocity = pose_difference(object.pose, it->second.pose);
    object.pose = it->second.pose;
    object.confidence = it->second.confidence;
    object.held = it->second.held;
    object.stale = false;
  }
  if (options_.carry.frames > 0 || options_.companion.contact_distance > 0.f ||
      options_.join_split.overlap_frames > 0) {
    // The bounding spheres of the touch tests' prefilter.
    contact_.new_frame();
    for (const auto& [id, object] : objects_) {
      float radius = 0.f;
      for (const Eigen::Vector3f& p : object.model.cloud.positions) radius = std::max(radius, p.norm());
      tracked_.at(id).model_radius = radius;
    }
  }
}

void ObjectManager::segment(const ColoredCloud& scene) {
  seg_objects_.clear();
  for (const auto& [id, object] : objects_) {
    seg_objects_.push_back({id, object.model.cloud.positions, object.pose});
  }
  segmenter_.segment(scene.positions, seg_objects_, segmentation_, &pool_);
  frame_.labels = segmentation_.labels;
}

void ObjectManager::update_models(const ColoredCloud& scene) {
  for (std::size_t k = 0; k < segmentation_.object_ids.size(); ++k) {
    ManagedObject& object = objects_.at(segmentation_.object_ids[k]);
    object.support = segmentation_.counts[k];
    if (object.stale || object.support == 0 || options_.model_update.alpha <= 0.f) continue;
    object.model =
        tracked_.at(object.id).updater->update(object.model, scene, segmentation_.labels, object.id, object.pose);
    object.part_ends.assign(1, static_cast<std::uint32_t>(object.model.cloud.size()));  // mixed: one part
    ++object.version;
  }
}

void ObjectManager::retire_unsupported(const ColoredCloud& scene) {
  hidden_.assign(segmentation_.object_ids.size(), 0);
  for (std::size_t k = 0; k < segmentation_.object_ids.size(); ++k) {
    if (options_.hidden_occluded_share <= 0.f || segmentation_.counts[k] >= options_.support.min_points) continue;
    const ManagedObject& object = objects_.at(segmentation_.object_ids[k]);
    // A carried object is hidden behind its carrier wherever the occlusion test puts it (an object that
    // left the view is held too, but nothing carries it: it retires).
    hidden_[k] =
        object.carried_by != 0 || scene_occlusion(scene).occluded_share(object.model.cloud.positions, object.pose) >=
                                      options_.hidden_occluded_share;
  }
  support_.update(segmentation_.object_ids, segmentation_.counts, hidden_, frame_.retired);
  for (const std::int32_t id : gripped_away_) {
    if (std::find(frame_.retired.begin(), frame_.retired.end(), id) == frame_.retired.end()) {
      frame_.retired.push_back(id);
    }
  }
  for (const std::int32_t id : frame_.retired) {
    if (options_.reidentify_frames > 0) {
      const ManagedObject& object = objects_.at(id);
      retired_.remember(id, {frames_, object.version, color_histogram(object.model), tracked_.at(id).first_seen,
                             object.model, object.pose, object.part_ends});
    }
    forget(id);
  }
  // A retired object's few segmented points are unexplained now: they must not pass its id on.
  if (!frame_.retired.empty()) {
    for (std::int32_t& label : frame_.labels) {
      if (label != 0 && !objects_.contains(label)) label = 0;
    }
  }
  retired_.expire(frames_, options_.reidentify_frames);
}

void ObjectManager::index_clusters(std::span<const std::int32_t> cluster_of_point) {
  clusters_.point_indices.clear();
  clusters_.offsets.assign(1, 0);
  clusters_.cluster_of_point.assign(cluster_of_point.begin(), cluster_of_point.end());
  std::int32_t num_clusters = 0;
  for (const std::int32_t c : cluster_of_point) num_clusters = std::max(num_clusters, c + 1);
  std::vector<int> sizes(static_cast<std::size_t>(num_clusters), 0);
  for (const std::int32_t c : cluster_of_point) {
    if (c >= 0) ++sizes[static_cast<std::size_t>(c)];
  }
  for (const int s : sizes) clusters_.offsets.push_back(clusters_.offsets.back() + s);
  clusters_.point_indices.resize(static_cast<std::size_t>(clusters_.offsets.back()));
  std::vector<int> fill(clusters_.offsets.begin(), clusters_.offsets.end() - 1);
  for (std::size_t i = 0; i < cluster_of_point.size(); ++i) {
    const std::int32_t c = cluster_of_point[i];
    if (c >= 0)
      clusters_.point_indices[static_cast<std::size_t>(fill[static_cast<std::size_t>(c)]++)] = static_cast<int>(i);
  }
}

void ObjectManager::propagate_and_create(const ColoredCloud& scene) {
  if (frames_ == 0 && objects_.empty()) {  // the first frame: every cluster, nothing to propagate
    // Nothing is labelled yet, so each cluster's parts are found from its own points: all side by side.
    std::vector<std::vector<int>> free_points(standing_clusters_);
    for (std::size_t c = 0; c < standing_clusters_; ++c) free_points[c] = unexplained_points(clusters_.cluster(c));
    std::vector<std::vector<std::vector<int>>> parts(standing_clusters_);
    if (parts_.enabled()) {
      std::vector<std::vector<int>> split;  // the clusters large enough to split
      for (const std::vector<int>& points : free_points)
        split.push_back(points.size() >= 2 * options_.min_object_points ? points : std::vector<int>{});
      parts_.find(scene, split, parts);
    }
    for (std::size_t c = 0; c < standing_clusters_; ++c) create_objects(scene, free_points[c], &parts[c]);
    return;
  }
  for (std::size_t c = 0; c < clusters_.size(); ++c) propagate_labels(scene, clusters_.cluster(c));  // 5
  detector_.update(scene.positions, clusters_, frame_.labels, confirmed_, standing_clusters_);       // 6
  for (const int c : confirmed_) {
    std::vector<int> free_points = unexplained_points(clusters_.cluster(static_cast<std::size_t>(c)));
    if (free_points.size() < options_.min_object_points || inside_held_object(scene, free_points)) continue;
    if (const std::int32_t entered_with = entering_with(scene, free_points); entered_with != 0) {
      for (const int i : free_points) frame_.labels[static_cast<std::size_t>(i)] = entered_with;
      gain_points(entered_with, scene, free_points);
      continue;
    }
    create_objects(scene, free_points);
  }
  if (!grown_.empty()) reidentify_grown_objects(scene);
}

void ObjectManager::join_and_split(const ColoredCloud& scene, std::span<const std::int32_t> cluster_of_point) {
  if (options_.join_split.join_frames > 0) join_rigid_parts();
  if (options_.join_split.overlap_frames > 0) join_overlapping();
  if (options_.join_split.split_frames > 0) split_separated_parts(scene, cluster_of_point);
  if (parts_.enabled() && options_.discovery.confirm_frames > 0) confirm_discovery(scene);
}

std::vector<int> ObjectManager::unexplained_points(std::span<const int> cluster_points) const {
  std::vector<int> free_points;
  for (const int i : cluster_points) {
    if (frame_.labels[static_cast<std::size_t>(i)] == 0) free_points.push_back(i);
  }
  return free_points;
}

std::int32_t ObjectManager::entering_with(const ColoredCloud& scene, std::span<const int> free_points) {
  if (options_.entering_frames <= 0) return 0;
  entering_.cloud.clear();  // the unexplained points, camera frame: a model at the identity pose
  for (const int i : free_points) {
    entering_.cloud.push_back(scene.positions[static_cast<std::size_t>(i)], scene.colors[static_cast<std::size_t>(i)]);
  }
  const PlacedModel entering{0, &entering_, Pose{}, 0.f};
  for (const auto& [id, object] : objects_) {  // ascending ids: the oldest of several
    if (object.created_frame == 0 || frames_ - object.created_frame > options_.entering_frames || object.stale)
      continue;
    if (contact_.models_touch(entering, placed(id), options_.entering_distance)) return id;
  }
  return 0;
}

bool ObjectManager::inside_held_object(const ColoredCloud& scene, std::span<const int> free_points) const {
  if (options_.held_birth_margin <= 0.f) return false;
  std::vector<int> outside(free_points.begin(), free_points.end());  // not yet inside a held object
  std::size_t inside = 0;
  for (const auto& [id, object] : objects_) {
    if (!object.held || outside.empty()) continue;
    const Eigen::AlignedBox3f box = model_bounding_box(object.model);
    if (box.isEmpty()) continue;
    // Its bounding sphere: a held estimate may be off in any rotation, so the box's own axes say little.
    const Eigen::Vector3f center = object.pose.isometry() * box.center();
    const float radius = 0.5f * box.diagonal().norm() + options_.held_birth_margin;
    std::erase_if(outside, [&](int i) {
      const bool within = (scene.positions[static_cast<std::size_t>(i)] - center).norm() <= radius;
      inside += within ? 1 : 0;
      return within;
    });
  }
  return !free_points.empty() && 2 * inside >= free_points.size();
}

void ObjectManager::propagate_labels(const ColoredCloud& scene, std::span<const int> cluster_points) {
  propagation_.propagate(scene.positions, cluster_points, frame_.labels, gained_);
  for (auto& [id, points] : gained_) gain_points(id, scene, points);
}

void ObjectManager::gain_points(std::int32_t id, const ColoredCloud& scene, std::vector<int>& points) {
  ManagedObject& object = objects_.at(id);
  object.support += points.size();
  // A young object grows by a part entering the view, not by a few fringe points.
  const bool young = frames_ - object.created_frame < options_.growth_frames;
  if (young && points.size() >= options_.min_object_points) {
    std::sort(points.begin(), points.end());
    grow_model(object, scene, points);
    grown_.push_back(id);
  }
}

void ObjectManager::refit_parts(const ColoredCloud& scene) {
  segmented_.clear();
  for (const auto& [id, object] : objects_) {
    if (!object.stale && !object.held && object.carried_by == 0 && object.part_ends.size() > 1) {
      segmented_.try_emplace(id);
    }
  }
  if (segmented_.empty()) return;
  for (std::size_t i = 0; i < scene.size(); ++i) {
    const auto it = segmented_.find(frame_.labels[i]);
    if (it != segmented_.end()) it->second.push_back(scene.positions[i]);
  }
  for (const auto& [id, points] : segmented_) {
    ManagedObject& object = objects_.at(id);
    if (refit_.refit(points, object.model.cloud.positions, object.part_ends, object.pose) > 0) ++object.version;
  }
}

void ObjectManager::grow_model(ManagedObject& object, const ColoredCloud& scene, std::span<const int> gained) {
  const Eigen::Isometry3f camera_to_object = object.pose.isometry().inverse();
  part_points_.clear();
  part_colors_.clear();
  for (const int g : gained) {
    const auto i = static_cast<std::size_t>(g);
    part_points_.push_back(camera_to_object * scene.positions[i]);
    part_colors_.push_back(scene.colors[i]);
  }
  // Over the size limit the model thins out evenly instead of refusing the new part: an arm
  // reaching further in stays covered, so tau keeps segmenting it where the clustering splits
  // it from the hand (grazing views of an arm pointing at the camera).
  object.model = with_part(std::move(object.model), part_points_, part_colors_, compute_smr(part_colors_, options_.smr),
                           options_.max_model_points, object.part_ends);
  ++object.version;
}

std::int32_t ObjectManager::carried_match(const ColorHistogram& histogram) const {
  std::int32_t best = 0;
  float best_similarity = options_.reidentify_similarity;
  for (const auto& [id, object] : objects_) {  // ascending ids: ties keep the oldest
    if (object.carried_by == 0) continue;
    const float similarity = color_similarity(histogram, color_histogram(object.model));
    if (similarity > best_similarity || (best == 0 && similarity >= best_similarity)) {
      best = id;
      best_similarity = similarity;
    }
  }
  return best;
}

bool ObjectManager::take_points_carried(std::int32_t id, const ColoredCloud& scene, std::span<const int> points) {
  ManagedObject& object = objects_.at(id);
  ManagedObject found;
  if (!keep_frame(object.model, object.pose, object.part_ends, scene, points, found)) return false;
  object.model = std::move(found.model);
  object.part_ends = std::move(found.part_ends);
  object.pose = found.pose;  // still carried this frame: its tracker moves its filter there
  object.support += points.size();
  ++object.version;
  for (const int i : points) frame_.labels[static_cast<std::size_t>(i)] = id;
  frame_.found_carried.push_back(id);
  return true;
}

void ObjectManager::create_objects(const ColoredCloud& scene, std::span<const int> free_points,
                                   const std::vector<std::vector<int>>* found_parts) {
  if (free_points.size() < options_.min_object_points) return;
  current_birth_ = next_birth_++;  // the objects of this cluster are siblings
  if (!parts_.enabled() || free_points.size() < 2 * options_.min_object_points) {
    create_object(scene, free_points);
    return;
  }
  std::vector<std::vector<std::vector<int>>> parts;
  if (!found_parts) {
    const std::vector<int> set(free_points.begin(), free_points.end());
    parts_.find(scene, std::span(&set, 1), parts);
    found_parts = &parts[0];
  }
  for (const auto& points : *found_parts) create_object(scene, points);
}

void ObjectManager::create_object(const ColoredCloud& scene, std::span<const int> free_points) {
  const std::size_t n = std::min(free_points.size(), options_.max_model_points);
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
  for (const int i : free_points) centroid += scene.positions[static_cast<std::size_t>(i)];
  centroid /= static_cast<float>(free_points.size());

  ManagedObject object;
  object.pose.translation = centroid;
  object.model.cloud.reserve(n);
  // Deterministic even subsampling keeps the model spread over the whole cluster.
  for (std::size_t k = 0; k < n; ++k) {
    const auto i = static_cast<std::size_t>(free_points[k * free_points.size() / n]);
    object.model.cloud.push_back(scene.positions[i] - centroid, scene.colors[i]);
  }
  object.model.features = compute_smr(object.model.cloud.colors, options_.smr);
  object.part_ends.assign(1, static_cast<std::uint32_t>(object.model.cloud.size()));
  const ColorHistogram histogram = color_histogram(object.model);
  std::int32_t known = frames_ > 0 ? retired_.match(histogram, frames_) : 0;
  if (known == 0 && options_.carry.frames > 0) {
    const std::int32_t carried = carried_match(histogram);
    if (carried != 0 && take_points_carried(carried, scene, free_points)) return;
  }
  if (known == 0) known = retire_unseen_match(histogram, object.model);
  if (known != 0) {
    take_id_back(known, scene, free_points, object);
  } else {
    if (next_id_ > kMaxObjectId) return;  // every id given (kMaxObjectId): no new object, never an overflow
    object.id = next_id_++;
  }
  object.support = free_points.size();
  const bool born_unknown = known == 0;
  const Eigen::Vector3f born_at = object.pose.translation;
  TrackedObject& tracked = add_object(std::move(object), free_points, histogram, current_birth_);
  tracked.born_unknown = born_unknown;
  if (parts_.enabled() && options_.discovery.confirm_frames > 0) tracked.confirm_born_at = born_at;
}

TrackedObject& ObjectManager::add_object(ManagedObject object, std::span<const int> points,
                                         const ColorHistogram& first_seen, std::uint64_t birth) {
  object.confidence = 1.f;
  object.created_frame = frames_;
  for (const int i : points) frame_.labels[static_cast<std::size_t>(i)] = object.id;
  ModelUpdateOptions update = options_.model_update;
  update.seed = options_.model_update.seed + static_cast<std::uint64_t>(object.id);
  TrackedObject& tracked = tracked_[object.id];
  tracked.updater = std::make_unique<ModelUpdater>(update);
  tracked.first_seen = first_seen;
  tracked.birth = birth;
  frame_.created.push_back(object.id);
  objects_.emplace(object.id, std::move(object));
  return tracked;
}

void ObjectManager::resume_object(ManagedObject object) {
  const std::int32_t id = object.id;
  if (id < 1 || id > kMaxObjectId) {
    throw std::invalid_argument("resume_object: id " + std::to_string(id) + " outside [1, " +
                                std::to_string(kMaxObjectId) + "]");
  }
  if (objects_.contains(id)) throw std::invalid_argument("resume_object: id " + std::to_string(id) + " in use");
  if (object.model.cloud.empty() || object.model.cloud.size() > options_.max_model_points) {
    throw std::invalid_argument("resume_object: object " + std::to_string(id) + " has " +
                                std::to_string(object.model.cloud.size()) + " model points, expected [1, " +
                                std::to_string(options_.max_model_points) + "]");
  }
  if (object.version < 0) throw std::invalid_argument("resume_object: negative version");
  object.confidence = 1.f;
  object.stale = false;
  object.held = false;
  object.support = 0;
  object.carried_by = 0;
  object.companion = 0;
  object.companion_motion = PoseVector::Zero();
  object.created_frame = frames_;
  object.part_ends = {static_cast<std::uint32_t>(object.model.cloud.size())};
  object.model.features = compute_smr(object.model.cloud.colors, options_.smr);  // this manager's SMR options
  ModelUpdateOptions update = options_.model_update;
  update.seed = options_.model_update.seed + static_cast<std::uint64_t>(id);
  TrackedObject& tracked = tracked_[id];
  tracked.updater = std::make_unique<ModelUpdater>(update);
  tracked.first_seen = color_histogram(object.model);
  tracked.birth = next_birth_++;  // born alone: never joined as a sibling
  retired_.forget(id);
  next_id_ = std::max(next_id_, id + 1);
  objects_.emplace(id, std::move(object));
}

void ObjectManager::take_id_back(std::int32_t known, const ColoredCloud& scene, std::span<const int> points,
                                 ManagedObject& object) {
  object.id = known;
  object.version = retired_.at(known).version + 1;  // versions of an id only ever increase
  const RetiredObject& retired = retired_.at(known);
  if (keep_frame(retired.model, retired.pose, retired.part_ends, scene, points, object)) {
    frame_.registered.push_back(known);
  }
  retired_.forget(known);
}

std::int32_t ObjectManager::retire_unseen_match(const ColorHistogram& histogram, const ObjectModel& model) {
  if (options_.reidentify_unseen_radius_ratio <= 0.f || options_.reidentify_frames <= 0) return 0;
  unseen_.clear();
  for (const auto& [id, object] : objects_) {
    if (object.created_frame == frames_ || (!object.held && object.support >= options_.support.min_points)) continue;
    unseen_.push_back({id, color_histogram(object.model), tracked_.at(id).first_seen, model_radius(object.model)});
  }
  const std::int32_t id =
      retired_.match_unseen(unseen_, histogram, model_radius(model), options_.reidentify_unseen_radius_ratio);
  if (id == 0) return 0;
  const ManagedObject& object = objects_.at(id);
  const auto candidate =
      std::find_if(unseen_.begin(), unseen_.end(), [id](const UnseenObject& u) { return u.id == id; });
  retired_.remember(id, {frames_, object.version, candidate->histogram, tracked_.at(id).first_seen, object.model,
                         object.pose, object.part_ends});
  forget(id);
  frame_.retired.push_back(id);
  std::replace(frame_.labels.begin(), frame_.labels.end(), id, 0);  // its points where it was held are not its own
  return id;
}

void ObjectManager::reidentify_grown_objects(const ColoredCloud& scene) {
  std::vector<int> points;
  for (const std::int32_t young : grown_) {
    if (!tracked_.at(young).born_unknown) continue;
    const ManagedObject& grown = objects_.at(young);
    const std::int32_t known = retired_.match(color_histogram(grown.model), grown.created_frame);
    if (known == 0) continue;
    // Too little of it yet to register the remembered model on: it may match again as it grows.
    if (static_cast<float>(grown.model.cloud.size()) <
        options_.reidentify_grown_min_share * static_cast<float>(retired_.at(known).model.cloud.size())) {
      continue;
    }
    points.clear();
    for (std::size_t i = 0; i < frame_.labels.size(); ++i) {
      if (frame_.labels[i] == young) points.push_back(static_cast<int>(i));
    }
    ManagedObject object = grown;  // its model and pose, unless the remembered model registers on its points
    take_id_back(known, scene, points, object);
    const TrackedObject& was = tracked_.at(young);
    const ColorHistogram first_seen = was.first_seen;
    const std::uint64_t birth = was.birth;
    const std::optional<Eigen::Vector3f> confirm_born_at = was.confirm_born_at;
    forget(young);
    frame_.retired.push_back(young);
    frame_.reidentified.emplace_back(young, known);
    add_object(std::move(object), points, first_seen, birth).confirm_born_at = confirm_born_at;
  }
}

bool ObjectManager::keep_frame(const ObjectModel& model, const Pose& pose, std::span<const std::uint32_t> part_ends,
                               const ColoredCloud& scene, std::span<const int> points, ManagedObject& object) {
  registration_points_.points.clear();
  registration_points_.colors.clear();
  for (const int i : points) {
    registration_points_.points.push_back(scene.positions[static_cast<std::size_t>(i)]);
    registration_points_.colors.push_back(scene.colors[static_cast<std::size_t>(i)]);
  }
  registration_points_.features = compute_smr(registration_points_.colors, options_.smr);
  const std::optional<Registration> found = registration_->register_model(model, registration_points_, pose.rotation);
  if (!found) return false;
  // The remembered model first (its points win their voxels when thinning), then the new points
  // in its frame.
  const Eigen::Isometry3f camera_to_object = found->pose.isometry().inverse();
  part_points_.clear();
  for (const Eigen::Vector3f& p : registration_points_.points) part_points_.push_back(camera_to_object * p);
  object.part_ends.assign(part_ends.begin(), part_ends.end());
  object.model = with_part(model, part_points_, registration_points_.colors, registration_points_.features,
                           options_.max_model_points, object.part_ends);
  object.pose = found->pose;
  return true;
}

void ObjectManager::forget(std::int32_t id) {
  carry_.forget(id);
  support_.forget(id);  // an id taken back at once starts its count afresh
  objects_.erase(id);
  tracked_.erase(id);
  confirmation_.forget(id);  // its siblings' watches
  joiner_.forget(id);        // its rigid-part pairs
  overlap_joiner_.forget(id);
}

OcclusionTest& ObjectManager::scene_occlusion(const ColoredCloud& scene) {
  if (!occlusion_scene_set_) {
    occlusion_.set_scene(scene.positions);
    occlusion_.set_view(view_);
    occlusion_scene_set_ = true;
  }
  return occlusion_;
}

void ObjectManager::carry_hidden(const ColoredCloud& scene) {
  carry_objects_.clear();
  for (const auto& [id, object] : objects_) {
    if (!object.stale) carry_objects_.push_back({id, object.pose, object.held});
  }
  const auto touch = [&](std::int32_t a, std::int32_t b) { return touching(a, b, options_.carry.contact_distance); };
  const auto seen_through = [&](std::int32_t id, const Pose& pose) {
    OcclusionTest& occlusion = scene_occlusion(scene);
    occlusion.set_model(objects_.at(id).model.cloud.positions, pose);
    return occlusion.seen_through_share();
  };
  for (const CarryMonitor::Carried& carried : carry_.update(carry_objects_, touch, seen_through)) {
    if (carried.gripped_away) {
      gripped_away_.push_back(carried.id);  // retired in step 4
      continue;
    }
    ManagedObject& object = objects_.at(carried.id);
    object.pose = carried.pose;
    object.velocity = pose_difference(*tracked_.at(carried.id).pose_before, carried.pose);
    object.carried_by = carried.carrier;
  }
}

void ObjectManager::choose_companions() {
  const CompanionOptions& o = options_.companion;
  for (auto& [id, object] : objects_) {
    object.companion = 0;
    object.companion_motion.setZero();
    if (object.stale) continue;
    float best_reach = 0.f;
    for (const auto& [other_id, other] : objects_) {
      if (other_id == id || other.stale || other.held || !companion_moved(other.velocity, o)) continue;
      const PoseVector increment = companion_increment(object.pose, other.pose, other.velocity);
      const float reach = increment_reach(increment, tracked_.at(id).model_radius);
      if (reach <= best_reach || !touching(id, other_id, o.contact_distance)) continue;
      best_reach = reach;
      object.companion = other_id;
      object.companion_motion = increment;
    }
  }
}

void ObjectManager::join_rigid_parts() {
  join_candidates_.clear();
  for (const auto& [id, object] : objects_) {
    join_candidates_.push_back({id, tracked_.at(id).birth, object.pose, object.stale});
  }
  const float distance = options_.join_split.join_contact_distance;
  const auto touch = [&](std::int32_t a, std::int32_t b) {
    return contact_.models_touch(placed(a), placed(b), distance);
  };
  join_pairs(joiner_.update(join_candidates_, touch));
}

void ObjectManager::join_overlapping() {
  overlap_candidates_.clear();
  for (const auto& [id, object] : objects_) {
    overlap_candidates_.push_back({id, !object.stale && !object.held && object.carried_by == 0});
  }
  const float distance = options_.join_split.join_contact_distance;
  const auto overlap = [&](std::int32_t a, std::int32_t b) {
    return contact_.overlap_share(placed(a), placed(b), distance);
  };
  join_pairs(overlap_joiner_.update(overlap_candidates_, overlap));
}

void ObjectManager::join_pairs(std::span<const std::pair<std::int32_t, std::int32_t>> joins) {
  for (const auto& [kept, joined] : joins) {
    if (objects_.count(kept) && objects_.count(joined)) join(kept, joined);
  }
}

PlacedModel ObjectManager::placed(std::int32_t id) const {
  const ManagedObject& object = objects_.at(id);
  return {id, &object.model, object.pose, tracked_.at(id).model_radius};
}

bool ObjectManager::touching(std::int32_t a, std::int32_t b, float distance) {
  return contact_.touching(placed(a), placed(b), distance);
}

void ObjectManager::join(std::int32_t kept_id, std::int32_t joined_id) {
  ManagedObject& kept = objects_.at(kept_id);
  const ManagedObject& joined = objects_.at(joined_id);
  const Eigen::Isometry3f kept_from_joined = kept.pose.isometry().inverse() * joined.pose.isometry();
  part_points_.clear();
  for (const Eigen::Vector3f& p : joined.model.cloud.positions) part_points_.push_back(kept_from_joined * p);
  // SMR features depend on colour only: the joined part's stay valid in the kept frame. Placed by the two poses: one
  // part.
  kept.model = with_part(std::move(kept.model), part_points_, joined.model.cloud.colors, joined.model.features,
                         options_.max_model_points, kept.part_ends);
  ++kept.version;
  kept.support += joined.support;
  for (std::int32_t& label : frame_.labels) {
    if (label == joined_id) label = kept_id;
  }
  frame_.joined.emplace_back(kept_id, joined_id);
  frame_.retired.push_back(joined_id);
  forget(joined_id);
}

void ObjectManager::split_separated_parts(const ColoredCloud& scene, std::span<const std::int32_t> cluster_of_point) {
  std::map<std::int32_t, std::map<std::int32_t, std::vector<int>>> parts;  // object -> cluster -> points
  for (std::size_t i = 0; i < frame_.labels.size(); ++i) {
    if (frame_.labels[i] != 0 && cluster_of_point[i] >= 0) {
      parts[frame_.labels[i]][cluster_of_point[i]].push_back(static_cast<int>(i));
    }
  }
  std::vector<std::int32_t> ids;
  for (const auto& [id, object] : objects_) ids.push_back(id);
  std::vector<int> own;
  std::vector<std::vector<int>> leaving;
  for (const std::int32_t id : ids) {
    ManagedObject& object = objects_.at(id);
    const auto occluded_share = [&] {
      return scene_occlusion(scene).occluded_share(object.model.cloud.positions, object.pose);
    };
    if (!splitter_.update(object.pose, object.stale, parts[id], scene.positions, occluded_share, tracked_.at(id).split,
                          own, leaving)) {
      continue;
    }
    rebuild_model(object, scene, own);
    current_birth_ = next_birth_++;
    for (const std::vector<int>& points : leaving) {
      for (const int i : points) frame_.labels[static_cast<std::size_t>(i)] = 0;
      const std::size_t before = frame_.created.size();
      create_object(scene, points);
      if (frame_.created.size() > before) frame_.split.emplace_back(id, frame_.created.back());
    }
  }
}

void ObjectManager::confirm_discovery(const ColoredCloud& scene) {
  const DiscoveryOptions& o = options_.discovery;
  std::vector<std::int32_t> leaving;  // objects whose first frames ended or that moved from where they were born
  for (auto& [id, tracked] : tracked_) {
    if (!tracked.confirm_born_at) continue;
    const ManagedObject& object = objects_.at(id);
    const bool left = frames_ - object.created_frame > o.confirm_frames ||
                      (object.pose.translation - *tracked.confirm_born_at).norm() > o.confirm_max_motion;
    if (!left) continue;
    leaving.push_back(id);
    tracked.confirm_born_at.reset();
  }
  if (!leaving.empty()) {
    const auto model_size = [&](std::int32_t id) { return objects_.at(id).model.cloud.size(); };
    for (const auto& [kept, joined] : confirmation_.unparted_siblings(leaving, model_size)) join(kept, joined);
  }
  // Still young objects by birth (the cluster they were found in), each with its segmented points.
  std::map<std::uint64_t, std::map<std::int32_t, std::vector<int>>> groups;
  std::map<std::int32_t, std::vector<int>*> points_of;
  for (const auto& [id, tracked] : tracked_) {
    if (!tracked.confirm_born_at) continue;
    const ManagedObject& object = objects_.at(id);
    if (frames_ - object.created_frame >= 1 && !object.stale) points_of[id] = &groups[tracked.birth][id];
  }
  confirmation_.keep_votes_of([&](std::uint64_t birth) { return groups.contains(birth); });
  if (groups.empty()) return;
  for (std::size_t i = 0; i < frame_.labels.size(); ++i) {
    const auto it = points_of.find(frame_.labels[i]);
    if (it != points_of.end()) it->second->push_back(static_cast<int>(i));
  }
  // Each group's parts depend on its own points only: all groups are split side by side, then matched in order.
  std::vector<std::vector<int>> all;
  std::vector<std::uint64_t> births;
  for (const auto& [birth, members] : groups) {
    std::vector<int>& points_of_group = all.emplace_back();
    for (const auto& [id, points] : members)
      points_of_group.insert(points_of_group.end(), points.begin(), points.end());
    if (points_of_group.size() < 2 * options_.min_object_points) {
      all.pop_back();
      continue;
    }
    births.push_back(birth);
  }
  std::vector<std::vector<std::vector<int>>> parts_of_group;
  parts_.find(scene, all, parts_of_group);
  for (std::size_t g = 0; g < births.size(); ++g) {
    const std::uint64_t birth = births[g];
    const std::map<std::int32_t, std::vector<int>>& members = groups.at(birth);
    const std::vector<std::vector<int>>& parts = parts_of_group[g];
    const PartMatch match = DiscoveryConfirmation::match(parts, frame_.labels);
    confirmation_.watch_siblings(members, match);
    if (confirmation_.vote(birth, match.disagrees(static_cast<std::size_t>(o.min_part_points)))) {
      adopt_parts(scene, birth, all[g], parts, match);
    }
  }
}

void ObjectManager::adopt_parts(const ColoredCloud& scene, std::uint64_t birth, std::span<const int> all,
                                const std::vector<std::vector<int>>& parts, const PartMatch& match) {
  std::set<std::int32_t> changed;                         // members whose points changed: their models are rebuilt
  std::set<std::pair<std::int32_t, std::int32_t>> moved;  // (from, to)
  for (std::size_t p = 0; p < parts.size(); ++p) {
    const std::int32_t to = match.member_of_part[p];
    if (to == 0) continue;
    for (const int i : parts[p]) {
      std::int32_t& label = frame_.labels[static_cast<std::size_t>(i)];
      if (label != to && match.part_of_member.contains(label)) {
        moved.emplace(label, to);
        changed.insert(label);
        changed.insert(to);
        label = to;
      }
    }
  }
  frame_.regrouped.insert(frame_.regrouped.end(), moved.begin(), moved.end());
  for (std::size_t p = 0; p < parts.size(); ++p) {
    if (match.member_of_part[p] != 0) continue;
    std::vector<int> points;  // a member that holds no part keeps its points
    std::map<std::int32_t, std::size_t> from;
    for (const int i : parts[p]) {
      const std::int32_t label = frame_.labels[static_cast<std::size_t>(i)];
      if (!match.part_of_member.contains(label)) continue;
      points.push_back(i);
      ++from[label];
    }
    if (points.size() < options_.min_object_points) continue;
    const std::int32_t split = std::max_element(from.begin(), from.end(), [](const auto& x, const auto& y) {
                                 return x.second < y.second;
                               })->first;
    for (const auto& [id, count] : from) changed.insert(id);
    for (const int i : points) frame_.labels[static_cast<std::size_t>(i)] = 0;
    current_birth_ = birth;
    const std::size_t before = frame_.created.size();
    create_object(scene, points);
    if (frame_.created.size() > before) frame_.split.emplace_back(split, frame_.created.back());
  }
  for (const std::int32_t id : changed) {
    std::vector<int> own;
    for (const int i : all) {
      if (frame_.labels[static_cast<std::size_t>(i)] == id) own.push_back(i);
    }
    rebuild_model(objects_.at(id), scene, own);
  }
}

void ObjectManager::rebuild_model(ManagedObject& object, const ColoredCloud& scene, std::span<const int> points) {
  const Eigen::Isometry3f camera_to_object = object.pose.isometry().inverse();
  ColoredCloud part;
  for (const int i : points)
    part.push_back(camera_to_object * scene.positions[static_cast<std::size_t>(i)],
                   scene.colors[static_cast<std::size_t>(i)]);
  const std::vector<std::uint32_t> keep = even_subset(part, options_.max_model_points);
  object.model.cloud.clear();
  for (const std::uint32_t k : keep) object.model.cloud.push_back(part.positions[k], part.colors[k]);
  object.model.features = compute_smr(object.model.cloud.colors, options_.smr);
  object.part_ends.assign(1, static_cast<std::uint32_t>(object.model.cloud.size()));
  ++object.version;
}

void ObjectManager::claimed_points(std::int32_t id, float margin, std::vector<Eigen::Vector3f>& out) const {
  out.clear();
  const auto it = objects_.find(id);
  if (it == objects_.end()) return;
  const Eigen::AlignedBox3f box = model_bounding_box(it->second.model);
  if (box.isEmpty()) return;
  const Eigen::Vector3f lo = box.min() - Eigen::Vector3f::Constant(margin);
  const Eigen::Vector3f hi = box.max() + Eigen::Vector3f::Constant(margin);
  const Pose& pose = it->second.pose;
  const Eigen::Matrix3f to_object = pose.rotation.conjugate().toRotationMatrix();
  for (const auto& [other_id, other] : objects_) {
    if (other_id == id) continue;
    const Eigen::Matrix3f rotation = other.pose.rotation.toRotationMatrix();
    for (const Eigen::Vector3f& m : other.model.cloud.positions) {
      const Eigen::Vector3f camera = rotation * m + other.pose.translation;
      const Eigen::Vector3f local = to_object * (camera - pose.translation);
      if ((local.array() >= lo.array()).all() && (local.array() <= hi.array()).all()) out.push_back(camera);
    }
  }
}

}  // namespace mfot
