#include "mfot/service/tracker_worker.hpp"

#include <spdlog/spdlog.h>

#include "mfot/frame_done_t.hpp"
#include "mfot/object_model_t.hpp"
#include "mfot/service/convert.hpp"
#include "mfot/service_status_t.hpp"

namespace mfot::service {

TrackerWorker::TrackerWorker(const TrackerConfig& config, TrackerIdentity identity, TrackerSink& sink,
                             MalformedCounter& malformed, std::function<Clock::time_point()> clock)
    : config_(config),
      identity_(std::move(identity)),
      sink_(sink),
      malformed_(malformed),
      clock_(std::move(clock)),
      tracker_(ObjectTrackerOptions{config.likelihood, config.filter, config.step}),
      scenes_(config.scenes),
      merger_(std::chrono::milliseconds(config.merger_timeout_ms)) {}

void TrackerWorker::on_status(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name) {
  service_status_t msg;
  if (!decode_message(rbuf, channel_name, msg, malformed_)) return;
  if (msg.service == "merger") merger_.heard(msg.envelope.sender, clock_());
}

void TrackerWorker::on_model(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name) {
  object_model_t msg;
  if (!decode_message(rbuf, channel_name, msg, malformed_)) return;
  if (msg.frame_seq < -1) {
    malformed_.record(channel_name, "invalid model", "frame_seq below -1");
    return;
  }
  if (msg.object_id < 1 || msg.object_id > kMaxObjectId || msg.worker_id < -1 || msg.worker_id > kMaxWorkerId) {
    malformed_.record(channel_name, "invalid model",
                      "object id " + std::to_string(msg.object_id) + " or worker id " + std::to_string(msg.worker_id) +
                          " out of range [1, " + std::to_string(kMaxObjectId) + "], [-1, " +
                          std::to_string(kMaxWorkerId) + "]");
    return;
  }
  // Only the group's merger assigns and takes objects: a model from another process while it is
  // alive is refused (counted), whoever it is addressed to.
  if (!merger_.accepts(msg.envelope.sender, clock_())) {
    malformed_.record(channel_name, "model from another merger",
                      "sender " + std::to_string(msg.envelope.sender) + " is not the group's merger (" +
                          std::to_string(merger_.owner().value_or(0)) + ")");
    return;
  }
  // Addressed to another worker, or to this worker id in another process (two processes given
  // one id): not ours, but the merger finished its frame.
  if (msg.worker_id != identity_.worker_id || msg.worker_instance != identity_.instance) {
    scenes_.frame_finished(msg.frame_seq);
    if (tracker_.has_object() && tracker_.object_id() == msg.object_id) {
      spdlog::info("object {} {}", msg.object_id, msg.worker_id < 0 ? "retired" : "moved to another worker");
      tracker_.drop();
      scenes_.object_dropped();
    }
    return;
  }
  // An edit of a version this worker does not hold (the one it was made of got lost, or went to an earlier
  // holder): nothing is taken; the scenes wait, and a heartbeat at once shows the merger this worker
  // behind, so it sends the whole model again.
  if (msg.is_delta && (!tracker_.has_object() || tracker_.object_id() != msg.object_id ||
                       tracker_.model_version() != msg.base_version)) {
    ++model_gaps_;
    heartbeat_now_ = true;
    sink_.note("model edit of object " + std::to_string(msg.object_id) + " v" + std::to_string(msg.base_version) +
               " not held (" + std::to_string(model_gaps_) + " times so far): waiting for the whole model");
    return;
  }
  ObjectModel model;
  Pose pose;
  PoseVector velocity;  // the filter learns its own velocity within two frames
  if (auto error = model_from_message(msg, model, pose, velocity, msg.is_delta ? &tracker_.model().cloud : nullptr)) {
    malformed_.record(channel_name, "invalid model", *error);
    return;
  }
  if (model.cloud.empty()) {
    malformed_.record(channel_name, "invalid model", "empty model assigned");
    return;
  }
  if (auto error = claimed_from_message(msg, claimed_)) {
    malformed_.record(channel_name, "invalid model", *error);
    return;
  }
  std::optional<PoseVector> companion_motion;
  if (auto error = companion_from_message(msg, companion_motion)) {
    malformed_.record(channel_name, "invalid model", *error);
    return;
  }
  // A model older than (or the same as) the one held arrived late or again: keep ours.
  if (!scenes_.accepts_model(msg.object_id, msg.frame_seq)) return;
  const std::size_t points = model.cloud.size();
  try {
    if (tracker_.set_model(msg.object_id, msg.version, model, pose, msg.carried_by != 0)) {
      spdlog::info("took object {} (model v{} of frame {}, {} points)", msg.object_id, msg.version, msg.frame_seq,
                   points);
    }
  } catch (const std::exception& e) {
    // A model the likelihood cannot take is refused like any invalid model; the worker goes on.
    malformed_.record(channel_name, "invalid model", e.what());
    return;
  }
  last_pose_ = pose;  // the merger's pose of this model's frame, until the next estimate
  // An edit is followed by its frame's frame_done_t, whose entry for this version carries the claimed
  // points and releases the scenes.
  if (msg.is_delta) return;
  // What the other objects claimed as of this model's frame goes with the scenes it releases.
  tracker_.set_claimed_points(claimed_);
  tracker_.set_companion_motion(companion_motion);
  // Scenes the merger had already finished when it sent this model are not ours to track.
  scenes_.model_received(msg.object_id, msg.frame_seq);
}

void TrackerWorker::on_model_request(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name) {
  object_model_t request;
  if (!decode_message(rbuf, channel_name, request, malformed_)) return;
  if (request.object_id < 1 || request.num_points != 0) {
    malformed_.record(channel_name, "invalid model request", "object_id below 1 or points in a request");
    return;
  }
  if (request.worker_id != identity_.worker_id || request.worker_instance != identity_.instance) return;
  if (!tracker_.has_object() || tracker_.object_id() != request.object_id) return;
  object_model_t report{};
  report.utime = now_utime();
  report.frame_seq = scenes_.last_done();
  report.object_id = tracker_.object_id();
  report.worker_id = identity_.worker_id;
  report.worker_instance = identity_.instance;
  report.version = tracker_.model_version();
  pose_to_arrays(last_pose_, report.position, report.orientation);
  model_to_message(tracker_.model(), report);
  spdlog::info("reporting object {} (model v{}, {} points) to a restarted merger", report.object_id, report.version,
               report.num_points);
  sink_.publish_model_report(report);
}

void TrackerWorker::on_frame_done(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name) {
  // A fresh message: lcm-gen's decode leaves an array whose count is 0 as it was.
  frame_done_t msg;
  if (!decode_message(rbuf, channel_name, msg, malformed_)) return;
  if (msg.frame_seq < -1) {
    malformed_.record(channel_name, "invalid frame end", "frame_seq below -1");
    return;
  }
  // Only the group's merger ends frames: an end from another process would drop or move the object held.
  if (!merger_.accepts(msg.envelope.sender, clock_())) {
    malformed_.record(channel_name, "frame end from another merger",
                      "sender " + std::to_string(msg.envelope.sender) + " is not the group's merger (" +
                          std::to_string(merger_.owner().value_or(0)) + ")");
    return;
  }
  const frame_done_object_t* held = nullptr;  // the entry of the object held
  const frame_done_object_t* mine = nullptr;  // the entry addressed to this worker process
  for (const frame_done_object_t& entry : msg.objects) {
    if (tracker_.has_object() && entry.object_id == tracker_.object_id()) held = &entry;
    if (entry.worker_id == identity_.worker_id && entry.worker_instance == identity_.instance) mine = &entry;
  }
  // This frame's model of the object held, when its version did not change (else the model itself comes, or is
  // sent again: scenes wait for it). Checked before anything changes.
  const bool model_of_frame = mine != nullptr && mine == held && mine->version == tracker_.model_version();
  Pose pose;
  std::optional<PoseVector> companion_motion;
  if (model_of_frame) {
    std::optional<std::string> error = pose_from_arrays(mine->position, mine->orientation, pose);
    if (!error) error = claimed_from_message(*mine, claimed_);
    if (!error) error = companion_from_message(*mine, companion_motion);
    if (error) {
      malformed_.record(channel_name, "invalid frame end", *error);
      return;
    }
  }
  if (tracker_.has_object() && (held == nullptr || held != mine)) {
    spdlog::info("object {} {}", tracker_.object_id(), held == nullptr ? "retired" : "moved to another worker");
    tracker_.drop();
    scenes_.object_dropped();
  }
  scenes_.frame_finished(msg.frame_seq);
  if (!model_of_frame || !scenes_.accepts_model(mine->object_id, msg.frame_seq)) return;
  if (mine->carried_by != 0) tracker_.carry_to(pose);
  tracker_.set_claimed_points(claimed_);
  tracker_.set_companion_motion(companion_motion);
  scenes_.model_received(mine->object_id, msg.frame_seq);
}

void TrackerWorker::on_scene(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name) {
  std::optional<Scene> scene = receive_scene(rbuf, channel_name, malformed_);
  if (!scene) return;
  const std::int64_t seq = scene->frame_seq;
  // Frames are tracked in sequence order only: a late (reordered) scene, or one the merger sends
  // again after this worker already has it, is refused.
  const std::int64_t skipped = scenes_.skipped();
  if (scenes_.add_scene(std::move(*scene)) == TrackerSceneQueue::Arrival::kNewSequence) {
    spdlog::info("scene seq {}: a new frame sequence", seq);
  }
  if (scenes_.skipped() != skipped) {
    sink_.note("skipped " + std::to_string(scenes_.skipped()) + " scenes (more than tracker.queue_scenes)");
  }
}

int TrackerWorker::step() {
  // An idle worker keeps its scenes too: if the merger assigns it an object while those frames
  // are still open, it tracks them at once instead of the merger waiting for it.
  int tracked = 0;
  while (auto scene = scenes_.next(clock_())) {
    if (!tracker_.has_object()) continue;
    track(*scene);
    ++tracked;
  }
  report_fallbacks();
  const auto now = clock_();
  // A skipped scene is said at once, so the merger does not wait for its estimate.
  if (now >= next_heartbeat_ || scenes_.skipped() != skipped_at_heartbeat_ || heartbeat_now_) heartbeat(now);
  return tracked;
}

void TrackerWorker::track(const Scene& scene) {
  const auto t0 = clock_();
  tracker_.set_view(scene.view);
  const TrackingStepResult result = tracker_.track(scene.cloud);
  spdlog::debug(
      "frame {} object {}: {} share {:.2f}, {} points scored, {} occluders left out, fit {:.3f}, seen through "
      "{:.3f}",
      scene.frame_seq, tracker_.object_id(), result.held ? "held" : "stepped", result.occluded_share,
      result.hypothesis_points, result.occluders_removed, result.fit, result.seen_through_share);
  tracker_estimate_t msg{};
  msg.utime = now_utime();
  msg.frame_seq = scene.frame_seq;
  msg.object_id = tracker_.object_id();
  msg.worker_id = identity_.worker_id;
  msg.model_version = tracker_.model_version();
  pose_to_arrays(result.estimate, msg.position, msg.orientation);
  last_pose_ = result.estimate;
  msg.confidence = result.confidence;
  msg.effective_sample_size = tracker_.filter().effective_sample_size();
  msg.num_particles = config_.filter.num_particles;
  msg.num_hypothesis_points = static_cast<std::int32_t>(result.hypothesis_points);
  msg.held = result.held;
  msg.compute_ms = static_cast<float>(std::chrono::duration<double, std::milli>(clock_() - t0).count());
  sink_.publish_estimate(msg);
}

void TrackerWorker::heartbeat(Clock::time_point now) {
  heartbeat_t hb{};
  hb.utime = now_utime();
  hb.worker_id = identity_.worker_id;
  hb.instance = identity_.instance;
  hb.host = identity_.host;
  hb.object_id = tracker_.has_object() ? tracker_.object_id() : -1;
  hb.last_frame_seq = scenes_.last_done();
  skipped_at_heartbeat_ = scenes_.skipped();
  heartbeat_now_ = false;
  sink_.publish_heartbeat(hb);
  next_heartbeat_ = now + std::chrono::milliseconds(config_.heartbeat_ms);
}

void TrackerWorker::report_fallbacks() {
  if (scenes_.gaps_passed() != reported_gaps_) {
    reported_gaps_ = scenes_.gaps_passed();
    spdlog::warn("tracked a scene ahead of a missing one ({} times so far)", reported_gaps_);
    sink_.note("tracked " + std::to_string(reported_gaps_) + " scenes ahead of a missing one");
  }
  if (scenes_.fallbacks() == reported_fallbacks_) return;
  reported_fallbacks_ = scenes_.fallbacks();
  spdlog::warn("tracked a scene without the previous frame's model after {} ms ({} times so far)",
               config_.scenes.model_wait.count(), reported_fallbacks_);
  sink_.note("tracked " + std::to_string(reported_fallbacks_) +
             " scenes without the previous frame's model (tracker.model_wait_ms)");
}

}  // namespace mfot::service
