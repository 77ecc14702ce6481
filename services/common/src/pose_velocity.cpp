#include "mfot/service/pose_velocity.hpp"

namespace mfot::service {

PoseVelocityEstimator::PoseVelocityEstimator(const Pose& world_from_camera)
    : world_rotation_(world_from_camera.rotation.cast<double>().normalized().toRotationMatrix()) {}

ObjectVelocity PoseVelocityEstimator::update(std::int32_t object_id, const Pose& pose, std::int64_t capture_utime,
                                             bool stale) {
  ObjectVelocity velocity;
  if (stale) return velocity;
  const Sample current{pose.translation.cast<double>(), pose.rotation.cast<double>().normalized(), capture_utime};
  const auto [it, first] = last_.try_emplace(object_id, current);
  if (first) return velocity;
  const Sample previous = it->second;
  it->second = current;
  if (capture_utime <= previous.capture_utime) return velocity;
  const double dt = static_cast<double>(capture_utime - previous.capture_utime) * 1e-6;
  velocity.linear = (current.position - previous.position) / dt;
  // Eigen's angle-axis of a quaternion takes the shorter way (angle in [0, pi]).
  const Eigen::AngleAxisd turn(current.rotation * previous.rotation.conjugate());
  velocity.angular = turn.angle() * turn.axis() / dt;
  velocity.world_linear = world_rotation_ * velocity.linear;
  velocity.world_angular = world_rotation_ * velocity.angular;
  return velocity;
}

}  // namespace mfot::service
