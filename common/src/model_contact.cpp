#include "mfot/model_contact.hpp"

#include <algorithm>

namespace mfot {

bool ModelContact::models_touch(const PlacedModel& a, const PlacedModel& b, float distance) {
  points_.clear();
  points_.reserve(a.model->cloud.size());
  const Eigen::Isometry3f a_pose = a.pose.isometry();
  for (const Eigen::Vector3f& p : a.model->cloud.positions) points_.push_back(a_pose * p);
  hash_ = SpatialHash(distance);
  hash_.build(points_);
  const Eigen::Isometry3f b_pose = b.pose.isometry();
  for (const Eigen::Vector3f& p : b.model->cloud.positions) {
    if (hash_.any_within(b_pose * p, distance)) return true;
  }
  return false;
}

bool ModelContact::touching(const PlacedModel& a, const PlacedModel& b, float distance) {
  const PlacedModel& lower = a.id < b.id ? a : b;
  const PlacedModel& higher = a.id < b.id ? b : a;
  const auto key = std::make_tuple(lower.id, higher.id, distance);
  if (const auto it = memo_.find(key); it != memo_.end()) return it->second;
  const float reach = a.radius + b.radius + distance;
  const bool touch =
      (lower.pose.translation - higher.pose.translation).norm() <= reach && models_touch(lower, higher, distance);
  memo_.emplace(key, touch);
  return touch;
}

}  // namespace mfot
