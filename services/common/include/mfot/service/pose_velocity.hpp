#pragma once
// Object velocities for MFOT_POSES from consecutive poses and the capture times of the frames they
// belong to (poses_t.capture_utime), so they hold at any camera rate and across dropped frames.
// Transport-free; one instance follows every object of one frame sequence.
//   linear  = (t_cur - t_prev) / dt: the velocity of the object origin, m/s;
//   angular = rotation vector (axis * angle, the angle in [0, pi]) of R_cur R_prev^T, divided by
//             dt: the object's turn expressed in the frame the poses are given in (R: object to
//             that frame), rad/s; R_cur = exp([angular * dt]x) R_prev;
// with dt = (capture_utime_cur - capture_utime_prev) / 1e6 s, "prev" the object's last pose that
// was not stale. Both are given in the camera frame and, rotated by world_from_camera, in the world
// frame. Zero velocity: an object's first pose, a stale pose (the tracker missed the frame; the
// next fresh pose then gives the mean velocity since the last fresh one), and a capture time not
// after the previous one (a new frame sequence: that pose starts over).

#include <Eigen/Core>
#include <cstdint>
#include <map>

#include "mfot/types.hpp"

namespace mfot::service {

struct ObjectVelocity {
  Eigen::Vector3d linear = Eigen::Vector3d::Zero();         // camera frame, m/s
  Eigen::Vector3d angular = Eigen::Vector3d::Zero();        // camera frame, rotation vector per second, rad/s
  Eigen::Vector3d world_linear = Eigen::Vector3d::Zero();   // world frame, m/s
  Eigen::Vector3d world_angular = Eigen::Vector3d::Zero();  // world frame, rad/s
};

class PoseVelocityEstimator {
 public:
  explicit PoseVelocityEstimator(const Pose& world_from_camera = Pose{});

  // Object `object_id` at `pose` (object to camera) in the frame captured at `capture_utime`
  // (microseconds); `stale`: the pose is the last one known, not of this frame.
  ObjectVelocity update(std::int32_t object_id, const Pose& pose, std::int64_t capture_utime, bool stale);
  // The object is gone (retired): its next pose, if its id comes back, is a first one.
  void forget(std::int32_t object_id) { last_.erase(object_id); }
  // Forgets every object whose id `keep` refuses.
  template <typename Keep>
  void forget_unless(Keep keep) {
    std::erase_if(last_, [&](const auto& entry) { return !keep(entry.first); });
  }

 private:
  struct Sample {
    Eigen::Vector3d position;
    Eigen::Quaterniond rotation;
    std::int64_t capture_utime;
  };
  Eigen::Matrix3d world_rotation_;       // world_from_camera's rotation
  std::map<std::int32_t, Sample> last_;  // each object's last fresh pose
};

}  // namespace mfot::service
