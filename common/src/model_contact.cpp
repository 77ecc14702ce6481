#include "mfot/model_contact.hpp"

#include <algorithm>

namespace mfot {

bool ModelContact::spheres_meet(const PlacedModel& a, const PlacedModel& b, float distance) {
  return (a.pose.translation - b.pose.translation).norm() <= a.radius + b.radius + distance;
}

void ModelContact::hash_placed(const PlacedModel& placed, float distance) {
  points_.clear();
  points_.reserve(placed.model->cloud.size());
  const Eigen::Isometry3f pose = placed.pose.isometry();
  for (const Eigen::Vector3f& p : placed.model->cloud.positions) points_.push_back(pose * p);
  hash_ = SpatialHash(distance);
  hash_.build(points_);
}

bool ModelContact::models_touch(const PlacedModel& a, const PlacedModel& b, float distance) {
  hash_placed(a, distance);
  const Eigen::Isometry3f b_pose = b.pose.isometry();
  for (const Eigen::Vector3f& p : b.model->cloud.positions) {
    if (hash_.any_within(b_pose * p, distance)) return true;
  }
  return false;
}

float ModelContact::overlap_share(const PlacedModel& a, const PlacedModel& b, float distance) {
  if (!spheres_meet(a, b, distance)) return 0.f;
  const bool a_smaller = a.model->cloud.size() <= b.model->cloud.size();
  const PlacedModel& small = a_smaller ? a : b;
  const PlacedModel& large = a_smaller ? b : a;
  if (small.model->cloud.size() == 0) return 0.f;
  hash_placed(large, distance);
  const Eigen::Isometry3f small_pose = small.pose.isometry();
  std::size_t shared = 0;
  for (const Eigen::Vector3f& p : small.model->cloud.positions) shared += hash_.any_within(small_pose * p, distance);
  return static_cast<float>(shared) / static_cast<float>(small.model->cloud.size());
}

bool ModelContact::touching(const PlacedModel& a, const PlacedModel& b, float distance) {
  const PlacedModel& lower = a.id < b.id ? a : b;
  const PlacedModel& higher = a.id < b.id ? b : a;
  const auto key = std::make_tuple(lower.id, higher.id, distance);
  if (const auto it = memo_.find(key); it != memo_.end()) return it->second;
  const bool touch = spheres_meet(lower, higher, distance) && models_touch(lower, higher, distance);
  memo_.emplace(key, touch);
  return touch;
}

}  // namespace mfot
