#include "mfot/occlusion.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace mfot {

namespace {

const OcclusionOptions& validated(const OcclusionOptions& options) {
  options.validate();
  return options;
}

// The pose's transform with its rotation normalised (a pose read from a message or averaged may drift off unit).
Eigen::Isometry3f object_to_camera(const Pose& pose) {
  Pose unit = pose;
  unit.rotation.normalize();
  return unit.isometry();
}

// A point's camera ray as the cone indexes store it: (x/z, y/z, 0).
Eigen::Vector3f ray(const Eigen::Vector3f& p) { return {p.x() / p.z(), p.y() / p.z(), 0.f}; }

}  // namespace

void OcclusionOptions::validate() const {
  if (!(window > 0.f && window <= 0.1f)) {
    throw std::invalid_argument("OcclusionOptions.window must be in (0, 0.1], got " + std::to_string(window));
  }
  if (!(depth_margin >= 0.f && depth_margin <= 1.f)) {
    throw std::invalid_argument("OcclusionOptions.depth_margin must be in [0, 1] metres, got " +
                                std::to_string(depth_margin));
  }
  if (!(own_surface_radius >= 0.f && own_surface_radius <= 0.1f)) {
    throw std::invalid_argument("OcclusionOptions.own_surface_radius must be in [0, 0.1] metres, got " +
                                std::to_string(own_surface_radius));
  }
}

ViewBounds ViewBounds::of_image(int width, int height, float fx, float fy, float cx, float cy) {
  return {(-0.5f - cx) / fx, (static_cast<float>(width) - 0.5f - cx) / fx, (-0.5f - cy) / fy,
          (static_cast<float>(height) - 0.5f - cy) / fy};
}

OcclusionTest::OcclusionTest(const OcclusionOptions& options)
    : options_(validated(options)),
      ray_hash_(options.window),
      own_hash_(std::max(options.own_surface_radius, 1e-3f)),
      model_ray_hash_(options.window) {
  ray_hash_.build({});
}

void OcclusionTest::index_rays(std::span<const Eigen::Vector3f> points, std::vector<Eigen::Vector3f>& rays,
                               std::vector<Eigen::Vector3f>& sources, SpatialHash& hash) {
  rays.clear();
  sources.clear();
  for (const auto& p : points) {
    if (!(p.z() > 0.f)) continue;
    rays.push_back(ray(p));
    sources.push_back(p);
  }
  hash.build(rays);
}

void OcclusionTest::set_scene(std::span<const Eigen::Vector3f> scene_points) {
  index_rays(scene_points, ray_points_, ray_scene_, ray_hash_);
}

template <class IsOccluder>
bool OcclusionTest::occluded_by(const Eigen::Vector3f& point, IsOccluder&& is_occluder) const {
  if (!(point.z() > 0.f)) return true;
  const float in_front = point.z() - options_.depth_margin;
  return ray_hash_.any_within(ray(point), options_.window, [&](int i) {
    const auto k = static_cast<std::size_t>(i);
    return ray_scene_[k].z() < in_front && is_occluder(k);
  });
}

bool OcclusionTest::occluded(const Eigen::Vector3f& point) const {
  return occluded_by(point, [](std::size_t) { return true; });
}

void OcclusionTest::set_model(std::span<const Eigen::Vector3f> model_points, const Pose& pose) {
  const Eigen::Isometry3f to_camera = object_to_camera(pose);
  own_points_.clear();
  for (const auto& p : model_points) own_points_.push_back(to_camera * p);
  if (options_.own_surface_radius > 0.f) own_hash_.build(own_points_);
  model_rays_indexed_ = false;
}

float OcclusionTest::occluded_share() {
  if (own_points_.empty()) return 0.f;
  // A scene point lies on the cones of several model points (its near and far side): whether it is the
  // object's own surface is asked of the model's hash once per set model.
  scene_on_own_surface_.assign(ray_scene_.size(), kUnknown);
  const auto not_own_surface = [&](std::size_t k) {
    if (options_.own_surface_radius <= 0.f) return true;
    if (scene_on_own_surface_[k] == kUnknown) {
      scene_on_own_surface_[k] = own_hash_.any_within(ray_scene_[k], options_.own_surface_radius) ? kYes : kNo;
    }
    return scene_on_own_surface_[k] == kNo;
  };
  std::size_t occluded_points = 0;
  for (const auto& m : own_points_) {
    if (occluded_by(m, not_own_surface)) ++occluded_points;
  }
  return static_cast<float>(occluded_points) / static_cast<float>(own_points_.size());
}

float OcclusionTest::occluded_share(std::span<const Eigen::Vector3f> model_points, const Pose& pose) {
  set_model(model_points, pose);
  return occluded_share();
}

bool OcclusionTest::seen_through(const Eigen::Vector3f& m) const {
  if (!(m.z() > 0.f)) return false;
  if (view_ && !view_->contains(m.x() / m.z(), m.y() / m.z())) return false;
  const float behind = m.z() + options_.depth_margin;
  return !ray_hash_.any_within(ray(m), options_.window,
                               [&](int i) { return !(ray_scene_[static_cast<std::size_t>(i)].z() > behind); });
}

float OcclusionTest::seen_through_share() {
  if (own_points_.empty()) return 0.f;
  std::size_t seen = 0;
  for (const auto& m : own_points_) seen += seen_through(m) ? 1 : 0;
  return static_cast<float>(seen) / static_cast<float>(own_points_.size());
}

float OcclusionTest::seen_through_share(std::span<const Eigen::Vector3f> model_points, const Pose& pose,
                                        int max_points) const {
  if (max_points < 1) throw std::invalid_argument("OcclusionTest::seen_through_share needs max_points >= 1");
  if (model_points.empty()) return 0.f;
  const Eigen::Isometry3f to_camera = object_to_camera(pose);
  const std::size_t stride =
      (model_points.size() + static_cast<std::size_t>(max_points) - 1) / static_cast<std::size_t>(max_points);
  std::size_t tested = 0;
  std::size_t seen = 0;
  for (std::size_t k = 0; k < model_points.size(); k += stride) {
    ++tested;
    seen += seen_through(to_camera * model_points[k]) ? 1 : 0;
  }
  return static_cast<float>(seen) / static_cast<float>(tested);
}

std::size_t OcclusionTest::remove_occluders(HypothesisData& data) {
  if (own_points_.empty() || data.points.empty()) return 0;
  if (!model_rays_indexed_) {
    index_rays(own_points_, model_rays_, model_ray_points_, model_ray_hash_);
    model_rays_indexed_ = true;
  }
  const auto occludes = [&](const Eigen::Vector3f& p) {
    if (!(p.z() > 0.f)) return false;
    if (options_.own_surface_radius > 0.f && own_hash_.any_within(p, options_.own_surface_radius)) return false;
    const float behind = p.z() + options_.depth_margin;
    return model_ray_hash_.any_within(
        ray(p), options_.window, [&](int i) { return model_ray_points_[static_cast<std::size_t>(i)].z() > behind; });
  };
  std::size_t kept = 0;
  const std::size_t n = data.points.size();
  const bool has_features = data.features.size() == n;
  const bool has_colors = data.colors.size() == n;
  for (std::size_t k = 0; k < n; ++k) {
    if (occludes(data.points[k])) continue;
    data.points[kept] = data.points[k];
    if (has_features) data.features[kept] = data.features[k];
    if (has_colors) data.colors[kept] = data.colors[k];
    ++kept;
  }
  data.points.resize(kept);
  if (has_features) data.features.resize(kept);
  if (has_colors) data.colors.resize(kept);
  return n - kept;
}

}  // namespace mfot
