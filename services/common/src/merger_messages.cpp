#include "mfot/service/merger_messages.hpp"

#include "mfot/service/convert.hpp"

namespace mfot::service {

namespace {
// Bytes of a point on the wire: x, y, z float32 and r, g, b bytes; of a claimed point x, y, z; of a run int32.
constexpr std::size_t kPointBytes = 15, kClaimedBytes = 12, kRunBytes = 4;
}  // namespace

object_model_t model_message(const ManagedObject& object, std::int32_t worker_id, std::int64_t worker_instance,
                             std::int64_t frame_seq, std::span<const Eigen::Vector3f> claimed, std::int64_t utime,
                             const HeldModel* held, ModelDiffer& differ) {
  object_model_t msg{};
  msg.utime = utime;
  msg.frame_seq = frame_seq;
  msg.object_id = object.id;
  msg.worker_id = worker_id;
  msg.worker_instance = worker_id >= 0 ? worker_instance : 0;
  msg.version = object.version;
  pose_to_arrays(object.pose, msg.position, msg.orientation);
  for (int i = 0; i < 6; ++i) msg.velocity[i] = object.velocity[i];
  msg.carried_by = object.carried_by;
  msg.companion = object.companion;
  for (int i = 0; i < 6; ++i) msg.companion_motion[i] = object.companion_motion[i];
  if (held != nullptr && held->version >= 0 && held->version < object.version) {
    const ColoredCloud& model = object.model.cloud;
    const ModelDelta& delta = differ.diff(held->cloud, model);
    const std::size_t edit_bytes =
        delta.new_points.size() * kPointBytes + (delta.base_runs.size() + delta.order_runs.size()) * kRunBytes;
    if (edit_bytes < model.size() * kPointBytes + claimed.size() * kClaimedBytes) {
      ObjectModel new_points;  // the cloud alone goes on the wire
      new_points.cloud.reserve(delta.new_points.size());
      for (const std::uint32_t i : delta.new_points) new_points.cloud.push_back(model.positions[i], model.colors[i]);
      msg.is_delta = true;
      msg.base_version = held->version;
      msg.num_base_points = static_cast<std::int32_t>(held->cloud.size());
      msg.num_base_runs = static_cast<std::int32_t>(delta.base_runs.size());
      msg.base_runs = delta.base_runs;
      msg.num_order_runs = static_cast<std::int32_t>(delta.order_runs.size());
      msg.order_runs = delta.order_runs;
      model_to_message(new_points, msg);
      return msg;  // no claimed points: the frame_done_t that follows carries them
    }
  }
  model_to_message(object.model, msg);
  claimed_to_message(claimed, msg);
  return msg;
}

object_model_t model_message(const ManagedObject& object, std::int32_t worker_id, std::int64_t worker_instance,
                             std::int64_t frame_seq, std::span<const Eigen::Vector3f> claimed, std::int64_t utime) {
  ModelDiffer unused;
  return model_message(object, worker_id, worker_instance, frame_seq, claimed, utime, nullptr, unused);
}

void frame_done_entry(const ManagedObject& object, std::int32_t worker_id, std::int64_t worker_instance,
                      std::span<const Eigen::Vector3f> claimed, frame_done_object_t& out) {
  out.object_id = object.id;
  out.worker_id = worker_id;
  out.worker_instance = worker_id >= 0 ? worker_instance : 0;
  out.version = object.version;
  pose_to_arrays(object.pose, out.position, out.orientation);
  out.carried_by = object.carried_by;
  out.companion = object.companion;
  for (int i = 0; i < 6; ++i) out.companion_motion[i] = object.companion_motion[i];
  claimed_to_message(claimed, out);
}

object_model_t retirement_message(std::int32_t object_id, std::int64_t frame_seq, std::int64_t utime) {
  object_model_t msg{};
  msg.utime = utime;
  msg.frame_seq = frame_seq;
  msg.object_id = object_id;
  msg.worker_id = -1;
  msg.version = -1;
  msg.orientation[0] = 1;
  return msg;
}

poses_t poses_message(std::int64_t frame_seq, std::int64_t capture_utime,
                      const std::map<std::int32_t, ManagedObject>& objects, const Pose& world_from_camera,
                      PoseVelocityEstimator& velocities, std::int64_t utime) {
  poses_t poses{};
  poses.utime = utime;
  poses.frame_seq = frame_seq;
  poses.capture_utime = capture_utime;
  velocities.forget_unless([&objects](std::int32_t id) { return objects.count(id) > 0; });
  for (const auto& [id, object] : objects) {
    object_pose_t p{};
    p.id = id;
    pose_to_arrays(object.pose, p.position, p.orientation);
    pose_to_arrays(Pose::from_isometry(world_from_camera.isometry() * object.pose.isometry()), p.world_position,
                   p.world_orientation);
    const ObjectVelocity v = velocities.update(id, object.pose, capture_utime, object.stale);
    for (int i = 0; i < 3; ++i) {
      p.linear_velocity[i] = v.linear[i];
      p.angular_velocity[i] = v.angular[i];
      p.world_linear_velocity[i] = v.world_linear[i];
      p.world_angular_velocity[i] = v.world_angular[i];
    }
    p.confidence = object.confidence;
    p.stale = object.stale;
    poses.objects.push_back(p);
  }
  poses.num_objects = static_cast<std::int32_t>(poses.objects.size());
  return poses;
}

segmentation_t segmentation_message(std::int64_t frame_seq, std::span<const std::int32_t> labels, std::int64_t utime) {
  segmentation_t seg{};
  seg.utime = utime;
  seg.frame_seq = frame_seq;
  seg.num_points = static_cast<std::int32_t>(labels.size());
  seg.label.assign(labels.begin(), labels.end());
  return seg;
}

}  // namespace mfot::service
