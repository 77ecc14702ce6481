#include "mfot/service/merger_link.hpp"

#include <chrono>

#include "mfot/service/merger_messages.hpp"

namespace mfot::service {

MergerCoreOptions merger_core_options(const MergerConfig& config) {
  MergerCoreOptions options;
  options.manager = config.manager;
  options.workers.worker_timeout = std::chrono::milliseconds(config.worker_timeout_ms);
  options.frames.estimate_timeout = std::chrono::milliseconds(config.estimate_timeout_ms);
  options.frames.expected_workers = config.expected_workers;
  options.frames.startup_timeout = std::chrono::milliseconds(config.startup_timeout_ms);
  options.claimed_margin = config.claimed_margin;
  options.threads = config.threads;
  options.resume.listen = std::chrono::milliseconds(config.resume_listen_ms);
  options.resume.report_timeout = std::chrono::milliseconds(config.resume_timeout_ms);
  options.resume.max_model_points = config.manager.max_model_points;
  return options;
}

LcmMergerLink::LcmMergerLink(lcm::LCM& lcm, StatusReporter& status, const MergerConfig& config,
                             const std::optional<std::string>& output_dir, bool append)
    : lcm_(lcm), status_(status), world_from_camera_(config.world_from_camera), velocities_(config.world_from_camera) {
  if (!output_dir) return;
  // Label images are drawn from the log after the run (mfot-labels), not here.
  outputs_ = std::make_unique<RunOutputs>(
      *output_dir, append,
      RunOutputsOptions{.write_labels = false, .fitting_distance = config.fitting_distance, .background = true},
      status_.malformed());
}

void LcmMergerLink::send_model(const ManagedObject& object, std::int32_t worker_id, std::int64_t worker_instance,
                               std::int64_t frame_seq, std::span<const Eigen::Vector3f> claimed, std::int32_t recipient,
                               const HeldModel* held) {
  const object_model_t msg =
      model_message(object, worker_id, worker_instance, frame_seq, claimed, now_utime(), held, differ_);
  publish_message(lcm_, channel::model_channel(recipient), msg);
}

void LcmMergerLink::send_retirement(std::int32_t object_id, std::int64_t frame_seq, std::int32_t recipient) {
  const object_model_t msg = retirement_message(object_id, frame_seq, now_utime());
  publish_message(lcm_, channel::model_channel(recipient), msg);
}

void LcmMergerLink::send_frame_done(frame_done_t& message) {
  message.utime = now_utime();
  publish_message(lcm_, channel::kFrameDone, message);
}

void LcmMergerLink::request_model(std::int32_t object_id, std::int32_t worker_id, std::int64_t worker_instance) {
  object_model_t msg{};  // no points: a request (TrackerWorker::on_model_request)
  msg.utime = now_utime();
  msg.frame_seq = -1;
  msg.object_id = object_id;
  msg.worker_id = worker_id;
  msg.worker_instance = worker_instance;
  msg.orientation[0] = 1;
  publish_message(lcm_, channel::kModelRequest, msg);
}

void LcmMergerLink::resend_scene(std::span<const std::uint8_t> message) {
  // Re-stamped as ours: receivers already accepted preprocess's sequence number for it.
  publish_encoded(lcm_, channel::kScene, std::vector<std::uint8_t>(message.begin(), message.end()));
}

void LcmMergerLink::publish_frame(const FinishedFrame& frame) {
  const Scene& scene = frame.scene;
  const segmentation_t seg = segmentation_message(scene.frame_seq, frame.result.labels, now_utime());
  publish_message(lcm_, channel::kSegmentation, seg);
  const poses_t poses =
      poses_message(scene.frame_seq, scene.capture_utime, frame.objects, world_from_camera_, velocities_, now_utime());
  if (outputs_) outputs_->write_poses(scene.frame_seq, scene.capture_utime, frame.objects);
  publish_message(lcm_, channel::kPoses, poses);
  // The files that only evaluation reads come after the poses, off the frame-to-pose path (in
  // lockstep the next frame is on its way meanwhile).
  if (outputs_) outputs_->write_frame(scene, frame.result.labels, frame.objects, std::nullopt);
  status_.frame_done(
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - frame.due_at).count());
}

void LcmMergerLink::finish() {
  if (outputs_) outputs_->finish();
}

}  // namespace mfot::service
