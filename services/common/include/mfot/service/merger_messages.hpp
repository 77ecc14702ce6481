#pragma once
// The merger's outgoing messages, built from the core's objects: an object's model for its owner,
// a frame's end (frame_done_t), a retirement, the controller-facing poses and the segmentation of a frame.

#include <cstdint>
#include <map>
#include <span>

#include "mfot/frame_done_t.hpp"
#include "mfot/object_manager.hpp"
#include "mfot/object_model_t.hpp"
#include "mfot/poses_t.hpp"
#include "mfot/segmentation_t.hpp"
#include "mfot/service/model_delta.hpp"
#include "mfot/service/pose_velocity.hpp"

namespace mfot::service {

// The object's model and pose as of frame `frame_seq`, for `worker_id` (-1: nobody owns it) in
// its process `worker_instance`, with the other objects' points claimed near it (camera frame). With `held` (the
// version the addressee holds, below the object's), an edit of it (is_delta, without the claimed points) when that
// is fewer bytes on the wire than the whole model with them; `differ` is the scratch that finds the edit.
object_model_t model_message(const ManagedObject& object, std::int32_t worker_id, std::int64_t worker_instance,
                             std::int64_t frame_seq, std::span<const Eigen::Vector3f> claimed, std::int64_t utime,
                             const HeldModel* held, ModelDiffer& differ);
// The whole model (held nullptr).
object_model_t model_message(const ManagedObject& object, std::int32_t worker_id, std::int64_t worker_instance,
                             std::int64_t frame_seq, std::span<const Eigen::Vector3f> claimed, std::int64_t utime);
// The object's entry in a frame_done_t: its owner `worker_id` (-1: none) in process `worker_instance`, its
// model version and what its tracker needs beside the model (as model_message); reuses out's capacity.
void frame_done_entry(const ManagedObject& object, std::int32_t worker_id, std::int64_t worker_instance,
                      std::span<const Eigen::Vector3f> claimed, frame_done_object_t& out);
// worker_id = -1, num_points = 0: the object is gone.
object_model_t retirement_message(std::int32_t object_id, std::int64_t frame_seq, std::int64_t utime);
// Every object's pose in the camera and world frame and its velocity in both (`velocities` follows the
// objects from frame to frame: objects not in `objects` are forgotten).
poses_t poses_message(std::int64_t frame_seq, std::int64_t capture_utime,
                      const std::map<std::int32_t, ManagedObject>& objects, const Pose& world_from_camera,
                      PoseVelocityEstimator& velocities, std::int64_t utime);
segmentation_t segmentation_message(std::int64_t frame_seq, std::span<const std::int32_t> labels, std::int64_t utime);

}  // namespace mfot::service
