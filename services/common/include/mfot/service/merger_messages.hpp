#pragma once
// The merger's outgoing messages, built from the core's objects: an object's model for its owner,
// a retirement, the controller-facing poses and the segmentation of a frame.

#include "mfot/object_manager.hpp"
#include "mfot/object_model_t.hpp"
#include "mfot/poses_t.hpp"
#include "mfot/segmentation_t.hpp"

#include <cstdint>
#include <map>
#include <span>

namespace mfot::service {

// The object's model and pose as of frame `frame_seq`, for `worker_id` (-1: nobody owns it) in
// its process `worker_instance`, with the other objects' points claimed near it (camera frame).
object_model_t model_message(const ManagedObject& object, std::int32_t worker_id, std::int64_t worker_instance,
                             std::int64_t frame_seq, std::span<const Eigen::Vector3f> claimed, std::int64_t utime);
// worker_id = -1, num_points = 0: the object is gone.
object_model_t retirement_message(std::int32_t object_id, std::int64_t frame_seq, std::int64_t utime);
// Every object's pose in the camera and world frame, velocity per second (`fps` frames a second).
poses_t poses_message(std::int64_t frame_seq, std::int64_t capture_utime,
                      const std::map<std::int32_t, ManagedObject>& objects, const Pose& world_from_camera, float fps,
                      std::int64_t utime);
segmentation_t segmentation_message(std::int64_t frame_seq, std::span<const std::int32_t> labels, std::int64_t utime);

}  // namespace mfot::service
