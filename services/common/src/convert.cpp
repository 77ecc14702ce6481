#include "mfot/service/convert.hpp"

#include <cmath>
#include <span>

#include "mfot/service/model_delta.hpp"

namespace mfot::service {

namespace {
// Points and colours into a message's x, y, z, r, g, b arrays (scene_cloud_t, object_model_t),
// reusing their capacity.
template <class Message>
void write_points(std::span<const Eigen::Vector3f> positions, std::span<const Rgb8> colors, Message& out) {
  const std::size_t n = positions.size();
  out.x.resize(n);
  out.y.resize(n);
  out.z.resize(n);
  out.r.resize(n);
  out.g.resize(n);
  out.b.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    out.x[i] = positions[i].x();
    out.y[i] = positions[i].y();
    out.z[i] = positions[i].z();
    out.r[i] = colors[i].r;
    out.g[i] = colors[i].g;
    out.b[i] = colors[i].b;
  }
}
}  // namespace

namespace {
bool finite3(float x, float y, float z) { return std::isfinite(x) && std::isfinite(y) && std::isfinite(z); }
}  // namespace

std::optional<std::string> scene_from_message(const scene_cloud_t& msg, Scene& out) {
  const auto n = static_cast<std::size_t>(msg.num_points);
  if (msg.num_points < 0) return "negative num_points";
  if (msg.x.size() != n || msg.y.size() != n || msg.z.size() != n || msg.r.size() != n || msg.g.size() != n ||
      msg.b.size() != n || msg.u.size() != n || msg.v.size() != n || msg.cluster.size() != n) {
    return "array sizes disagree with num_points";
  }
  if (!(msg.voxel_size > 0.f) || !std::isfinite(msg.voxel_size)) return "voxel_size must be finite and > 0";
  if (!finite3(msg.voxel_origin[0], msg.voxel_origin[1], msg.voxel_origin[2])) return "voxel_origin must be finite";
  // The image's size and intrinsics: all given (the preprocessor sends them) or size or fx 0 (not known).
  out.view.reset();
  if (msg.width != 0 && msg.height != 0 && msg.fx != 0.f) {
    if (msg.width < 0 || msg.height < 0) return "negative image size";
    if (!(msg.fx > 0.f && msg.fy > 0.f && std::isfinite(msg.fx) && std::isfinite(msg.fy)) || !std::isfinite(msg.cx) ||
        !std::isfinite(msg.cy)) {
      return "intrinsics must be finite with fx, fy > 0";
    }
    out.view = ViewBounds::of_image(msg.width, msg.height, msg.fx, msg.fy, msg.cx, msg.cy);
  }
  if (msg.num_standing_clusters < 0 || msg.num_standing_clusters > msg.num_clusters) {
    return "num_standing_clusters " + std::to_string(msg.num_standing_clusters) + " outside [0, num_clusters " +
           std::to_string(msg.num_clusters) + "]";
  }
  out.frame_seq = msg.frame_seq;
  out.standing_clusters = msg.num_standing_clusters;
  out.voxel_grid = VoxelGrid{.leaf = msg.voxel_size,
                             .corner = Eigen::Vector3f(msg.voxel_origin[0], msg.voxel_origin[1], msg.voxel_origin[2])};
  out.capture_utime = msg.capture_utime;
  out.cloud.clear();
  out.cloud.reserve(n);
  out.cluster.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!finite3(msg.x[i], msg.y[i], msg.z[i])) return "non-finite coordinate at point " + std::to_string(i);
    // Every cluster has a point, so an index beyond the point count is corrupt (and the merger
    // sizes per-cluster tables by the largest index).
    if (msg.cluster[i] < -1 || msg.cluster[i] >= msg.num_clusters || msg.cluster[i] >= msg.num_points) {
      return "cluster index " + std::to_string(msg.cluster[i]) + " out of range at point " + std::to_string(i);
    }
    out.cloud.push_back({msg.x[i], msg.y[i], msg.z[i]},
                        {static_cast<std::uint8_t>(msg.r[i]), static_cast<std::uint8_t>(msg.g[i]),
                         static_cast<std::uint8_t>(msg.b[i])});
    out.cluster[i] = msg.cluster[i];
  }
  return std::nullopt;
}

std::optional<Scene> receive_scene(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name,
                                   MalformedCounter& malformed) {
  scene_cloud_t msg;
  if (!decode_message(rbuf, channel_name, msg, malformed)) return std::nullopt;
  Scene scene;
  if (auto error = scene_from_message(msg, scene)) {
    malformed.record(channel_name, "invalid scene", *error);
    return std::nullopt;
  }
  return scene;
}

RgbdImageView image_view(const Frame& frame) {
  return {frame.width, frame.height, CameraIntrinsics{frame.fx, frame.fy, frame.cx, frame.cy}, frame.depth_mm,
          frame.color};
}

void scene_to_message(const SceneCloud& scene, const frame_t& source, scene_cloud_t& out) {
  const auto n = scene.size();
  out.frame_seq = source.seq;
  out.capture_utime = source.capture_utime;
  out.width = source.width;
  out.height = source.height;
  out.fx = source.fx;
  out.fy = source.fy;
  out.cx = source.cx;
  out.cy = source.cy;
  out.voxel_size = scene.voxel_grid.leaf;
  for (int i = 0; i < 3; ++i) out.voxel_origin[i] = scene.voxel_grid.corner[i];
  for (int i = 0; i < 4; ++i) out.plane[i] = scene.plane.valid ? scene.plane.coefficients[i] : 0.f;
  out.num_points = static_cast<std::int32_t>(n);
  write_points(scene.positions, scene.colors, out);
  out.u.assign(scene.pixel_u.begin(), scene.pixel_u.end());
  out.v.assign(scene.pixel_v.begin(), scene.pixel_v.end());
  out.cluster.assign(scene.cluster.begin(), scene.cluster.end());
  out.num_clusters = scene.num_clusters;
  out.num_standing_clusters = scene.standing_clusters;
}

void scene_from_cloud(const SceneCloud& cloud, const Frame& source, std::int64_t seq, Scene& out) {
  out.frame_seq = seq;
  out.capture_utime = source.capture_utime;
  out.voxel_grid = cloud.voxel_grid;
  out.cloud.positions = cloud.positions;
  out.cloud.colors = cloud.colors;
  out.cluster.assign(cloud.cluster.begin(), cloud.cluster.end());
  out.standing_clusters = cloud.standing_clusters;
  out.view = ViewBounds::of_image(source.width, source.height, source.fx, source.fy, source.cx, source.cy);
}

std::optional<std::string> pose_from_arrays(const double position[3], const double orientation[4], Pose& out) {
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(position[i])) return "non-finite position";
  }
  double norm2 = 0;
  for (int i = 0; i < 4; ++i) {
    if (!std::isfinite(orientation[i])) return "non-finite orientation";
    norm2 += orientation[i] * orientation[i];
  }
  if (std::abs(norm2 - 1.0) > 1e-3) return "orientation is not a unit quaternion";
  out.translation = Eigen::Vector3d(position[0], position[1], position[2]).cast<float>();
  out.rotation =
      Eigen::Quaterniond(orientation[0], orientation[1], orientation[2], orientation[3]).cast<float>().normalized();
  return std::nullopt;
}

void pose_to_arrays(const Pose& pose, double position[3], double orientation[4]) {
  for (int i = 0; i < 3; ++i) position[i] = pose.translation[i];
  orientation[0] = pose.rotation.w();
  orientation[1] = pose.rotation.x();
  orientation[2] = pose.rotation.y();
  orientation[3] = pose.rotation.z();
}

std::optional<std::string> model_from_message(const object_model_t& msg, ObjectModel& model, Pose& pose,
                                              PoseVector& velocity, const ColoredCloud* base) {
  const auto n = static_cast<std::size_t>(msg.num_points);
  if (msg.num_points < 0) return "negative num_points";
  if (msg.x.size() != n || msg.y.size() != n || msg.z.size() != n || msg.r.size() != n || msg.g.size() != n ||
      msg.b.size() != n) {
    return "array sizes disagree with num_points";
  }
  if (msg.num_base_runs < 0 || msg.base_runs.size() != static_cast<std::size_t>(msg.num_base_runs) ||
      msg.num_order_runs < 0 || msg.order_runs.size() != static_cast<std::size_t>(msg.num_order_runs)) {
    return "run array sizes disagree with num_base_runs / num_order_runs";
  }
  if (!msg.is_delta &&
      (msg.base_version != 0 || msg.num_base_points != 0 || msg.num_base_runs != 0 || msg.num_order_runs != 0)) {
    return "a whole model with an edit's base_version, num_base_points or runs";
  }
  if (msg.is_delta) {
    if (base == nullptr) return "a model edit where the whole model is needed";
    if (msg.base_version < 0 || msg.base_version >= msg.version) {
      return "edit of version " + std::to_string(msg.base_version) + " into version " + std::to_string(msg.version) +
             " (base_version must be in [0, version))";
    }
    if (msg.num_base_points < 0 || static_cast<std::size_t>(msg.num_base_points) != base->size()) {
      return "an edit of a base of " + std::to_string(msg.num_base_points) + " points, the base held has " +
             std::to_string(base->size());
    }
    if (msg.num_claimed != 0) return "claimed points in a model edit";
  }
  if (auto error = pose_from_arrays(msg.position, msg.orientation, pose)) return error;
  if (msg.carried_by < 0) return "negative carried_by";
  if (msg.carried_by != 0 && msg.carried_by == msg.object_id) return "an object carried by itself";
  for (int i = 0; i < 6; ++i) {
    if (!std::isfinite(msg.velocity[i])) return "non-finite velocity";
    velocity[i] = static_cast<float>(msg.velocity[i]);
  }
  ColoredCloud new_points;  // an edit's new points
  ColoredCloud& points = msg.is_delta ? new_points : model.cloud;
  points.clear();
  points.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!finite3(msg.x[i], msg.y[i], msg.z[i])) return "non-finite model point " + std::to_string(i);
    if (std::abs(msg.x[i]) > kMaxModelRadius || std::abs(msg.y[i]) > kMaxModelRadius ||
        std::abs(msg.z[i]) > kMaxModelRadius) {
      return "model point " + std::to_string(i) + " is more than " + std::to_string(kMaxModelRadius) +
             " m from the object origin";
    }
    points.push_back({msg.x[i], msg.y[i], msg.z[i]},
                     {static_cast<std::uint8_t>(msg.r[i]), static_cast<std::uint8_t>(msg.g[i]),
                      static_cast<std::uint8_t>(msg.b[i])});
  }
  if (msg.is_delta) {
    if (auto error = apply_model_delta(*base, msg.base_runs, msg.order_runs, new_points, model.cloud)) return error;
  }
  model.features = compute_smr(model.cloud.colors);
  return std::nullopt;
}

void model_to_message(const ObjectModel& model, object_model_t& msg) {
  const std::size_t n = model.cloud.size();
  msg.num_points = static_cast<std::int32_t>(n);
  write_points(model.cloud.positions, model.cloud.colors, msg);
}

namespace {
template <class Message>
std::optional<std::string> companion_of(const Message& msg, std::optional<PoseVector>& out) {
  out.reset();
  if (msg.companion < 0) return "negative companion";
  if (msg.companion == 0) return std::nullopt;
  if (msg.companion == msg.object_id) return "an object that is its own companion";
  PoseVector motion;
  for (int i = 0; i < 6; ++i) {
    if (!std::isfinite(msg.companion_motion[i])) return "non-finite companion_motion";
    motion[i] = static_cast<float>(msg.companion_motion[i]);
  }
  out = motion;
  return std::nullopt;
}

template <class Message>
std::optional<std::string> claimed_of(const Message& msg, std::vector<Eigen::Vector3f>& out) {
  out.clear();
  if (msg.num_claimed < 0) return "negative num_claimed";
  const auto n = static_cast<std::size_t>(msg.num_claimed);
  if (msg.claimed_x.size() != n || msg.claimed_y.size() != n || msg.claimed_z.size() != n) {
    return "claimed array sizes disagree with num_claimed";
  }
  out.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!finite3(msg.claimed_x[i], msg.claimed_y[i], msg.claimed_z[i])) {
      out.clear();
      return "non-finite claimed point " + std::to_string(i);
    }
    out.emplace_back(msg.claimed_x[i], msg.claimed_y[i], msg.claimed_z[i]);
  }
  return std::nullopt;
}

template <class Message>
void write_claimed(std::span<const Eigen::Vector3f> claimed, Message& msg) {
  msg.num_claimed = static_cast<std::int32_t>(claimed.size());
  msg.claimed_x.resize(claimed.size());
  msg.claimed_y.resize(claimed.size());
  msg.claimed_z.resize(claimed.size());
  for (std::size_t i = 0; i < claimed.size(); ++i) {
    msg.claimed_x[i] = claimed[i].x();
    msg.claimed_y[i] = claimed[i].y();
    msg.claimed_z[i] = claimed[i].z();
  }
}

}  // namespace

std::optional<std::string> companion_from_message(const object_model_t& msg, std::optional<PoseVector>& out) {
  return companion_of(msg, out);
}
std::optional<std::string> companion_from_message(const frame_done_object_t& msg, std::optional<PoseVector>& out) {
  return companion_of(msg, out);
}
std::optional<std::string> claimed_from_message(const object_model_t& msg, std::vector<Eigen::Vector3f>& out) {
  return claimed_of(msg, out);
}
std::optional<std::string> claimed_from_message(const frame_done_object_t& msg, std::vector<Eigen::Vector3f>& out) {
  return claimed_of(msg, out);
}
void claimed_to_message(std::span<const Eigen::Vector3f> claimed, object_model_t& msg) { write_claimed(claimed, msg); }
void claimed_to_message(std::span<const Eigen::Vector3f> claimed, frame_done_object_t& msg) {
  write_claimed(claimed, msg);
}

}  // namespace mfot::service
