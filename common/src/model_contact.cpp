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

float ModelContact::overlap_share(const PlacedModel& a, const PlacedModel& b, float distance) {
  if ((a.pose.translation - b.pose.translation).norm() > a.radius + b.radius + distance) return 0.f;
  const bool a_smaller = a.model->cloud.size() <= b.model->cloud.size();
  const PlacedModel& small = a_smaller ? a : b;
  const PlacedModel& large = a_smaller ? b : a;
  if (small.model->cloud.size() == 0) return 0.f;
  points_.clear();
  const Eigen::Isometry3f large_pose = large.pose.isometry();
  for (const Eigen::Vector3f& p : large.model->cloud.positions) points_.push_back(large_pose * p);
  hash_ = SpatialHash(distance);
  hash_.build(points_);
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
  const float reach = a.radius + b.radius + distance;
  const bool touch =
      (lower.pose.translation - higher.pose.translation).norm() <= reach && models_touch(lower, higher, distance);
  memo_.emplace(key, touch);
  return touch;
}

}  // namespace mfot
