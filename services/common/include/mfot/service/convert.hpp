#pragma once
// Conversions between LCM messages and the core's plain types, with validation: a message that
// fails (inconsistent sizes, NaN/Inf coordinates, non-unit quaternion) is reported as a string
// naming the problem and never reaches the core.

#include <optional>
#include <span>
#include <string>
#include <vector>

#include "mfot/frame_done_object_t.hpp"
#include "mfot/frame_t.hpp"
#include "mfot/likelihood.hpp"
#include "mfot/object_model_t.hpp"
#include "mfot/occlusion.hpp"
#include "mfot/preprocessing.hpp"
#include "mfot/scene_cloud_t.hpp"
#include "mfot/service/frame_codec.hpp"
#include "mfot/service/lcm_util.hpp"
#include "mfot/types.hpp"

namespace mfot::service {

struct Scene {
  std::int64_t frame_seq = 0;
  std::int64_t capture_utime = 0;
  VoxelGrid voxel_grid;                // the preprocessor's grid of this frame (SceneCloud)
  ColoredCloud cloud;                  // camera frame
  std::vector<std::int32_t> cluster;   // per point, -1 = none
  std::int32_t standing_clusters = 0;  // clusters [0, standing_clusters) may become objects (SceneCloud)
  std::optional<ViewBounds> view;      // the source image's field of view; nullopt: not given (size or fx 0)
};

// Returns an error text, or nullopt when the message is valid and `out` is filled.
std::optional<std::string> scene_from_message(const scene_cloud_t& msg, Scene& out);
// A received MFOT_SCENE, decoded and validated; nullopt, counted in `malformed`, when it is not one.
std::optional<Scene> receive_scene(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name,
                                   MalformedCounter& malformed);

// The preprocessor's view of a decoded frame (it must outlive the view).
RgbdImageView image_view(const Frame& frame);

// The preprocessed scene of `source` (its seq, capture time, size and intrinsics) into `out`,
// reusing its buffers; utime is left to the publisher.
void scene_to_message(const SceneCloud& scene, const frame_t& source, scene_cloud_t& out);
// The preprocessed scene of frame `seq` as the trackers and the merger receive it (what scene_from_message gives
// for the message scene_to_message makes of it), without the wire, into `out`, reusing its buffers.
void scene_from_cloud(const SceneCloud& cloud, const Frame& source, std::int64_t seq, Scene& out);

std::optional<std::string> pose_from_arrays(const double position[3], const double orientation[4], Pose& out);
void pose_to_arrays(const Pose& pose, double position[3], double orientation[4]);

// Model points lie within this many metres of the object origin on every axis (object frame): a
// table-top object, or a hand with its forearm, fits easily, and the tracker's JCSD grid stays
// bounded (a 3 m cube is 8.2M corners at the default 1.5 cm cell).
inline constexpr float kMaxModelRadius = 1.5f;

// The model of an object_model_t (object frame) with SMR features; error text on invalid data
// (including points beyond kMaxModelRadius). An edit (is_delta) is applied to `base`, the model of
// msg.base_version that the caller holds (apply_model_delta; `model` must not be it): an edit without a
// base, of a base of another size, or with claimed points is an error, as is a whole model with an
// edit's fields set.
std::optional<std::string> model_from_message(const object_model_t& msg, ObjectModel& model, Pose& pose,
                                              PoseVector& velocity, const ColoredCloud* base = nullptr);
void model_to_message(const ObjectModel& model, object_model_t& msg);
// The claimed points of a model message or a frame_done_t entry (num_claimed, claimed_x/y/z: camera
// frame, metres); an error names what is wrong (sizes disagreeing with num_claimed, a non-finite
// point), with out cleared.
std::optional<std::string> claimed_from_message(const object_model_t& msg, std::vector<Eigen::Vector3f>& out);
std::optional<std::string> claimed_from_message(const frame_done_object_t& msg, std::vector<Eigen::Vector3f>& out);
void claimed_to_message(std::span<const Eigen::Vector3f> claimed, object_model_t& msg);
void claimed_to_message(std::span<const Eigen::Vector3f> claimed, frame_done_object_t& msg);
// The companion's motion of a model message or a frame_done_t entry (companion > 0: companion_motion;
// 0: nullopt); an error names what is wrong (a negative companion, the object itself, a non-finite
// motion), out nullopt.
std::optional<std::string> companion_from_message(const object_model_t& msg, std::optional<PoseVector>& out);
std::optional<std::string> companion_from_message(const frame_done_object_t& msg, std::optional<PoseVector>& out);

}  // namespace mfot::service
