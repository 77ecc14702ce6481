#include "mfot/service/merger_core.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>
#include <variant>

#include "mfot/heartbeat_t.hpp"
#include "mfot/object_model_t.hpp"
#include "mfot/service/merger_messages.hpp"
#include "mfot/tracker_estimate_t.hpp"

namespace mfot::service {

void MergerCoreOptions::validate() const {
  manager.validate();
  try {
    workers.validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("workers: ") + e.what());
  }
  try {
    frames.validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("frames: ") + e.what());
  }
  try {
    resume.validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("resume: ") + e.what());
  }
  if (threads < 1 || threads > 64) {
    throw std::invalid_argument("MergerCoreOptions.threads must be in [1, 64], got " + std::to_string(threads));
  }
  if (!(claimed_margin >= 0.f && claimed_margin <= 1.f)) {
    throw std::invalid_argument("MergerCoreOptions.claimed_margin must be in [0, 1] metres, got " +
                                std::to_string(claimed_margin));
  }
}

MergerCore::MergerCore(MergerCoreOptions options, MergerSink& sink, MalformedCounter& malformed,
                       std::function<Clock::time_point()> clock)
    : manager_((options.validate(), options.manager),
               make_object_discoveries(options.manager.discovery, options.threads)),
      workers_(options.workers),
      frames_(options.frames),
      resumer_(options.resume, clock()),
      sink_(sink),
      malformed_(malformed),
      clock_(std::move(clock)),
      claimed_margin_(options.claimed_margin) {}

void MergerCore::on_scene(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name) {
  std::optional<Scene> scene = receive_scene(rbuf, channel_name, malformed_);
  if (!scene) return;
  const std::int64_t seq = scene->frame_seq;
  const auto* bytes = static_cast<const std::uint8_t*>(rbuf->data);
  const std::int64_t last_finished = frames_.last_finished_seq();
  switch (frames_.add_scene(std::move(*scene), {bytes, bytes + rbuf->data_size}, clock_())) {
    case FrameAssembler::Arrival::kNewSequence:
      spdlog::warn("scene seq {} after {}: a new frame sequence", seq, last_finished);
      break;
    case FrameAssembler::Arrival::kLate:
      sink_.note("late or repeated scene " + std::to_string(seq));
      break;
    case FrameAssembler::Arrival::kQueued:
    case FrameAssembler::Arrival::kRepeated:  // our own re-sent scene coming back
      break;
  }
}

void MergerCore::on_estimate(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name) {
  tracker_estimate_t msg;
  if (!decode_message(rbuf, channel_name, msg, malformed_)) return;
  ObjectEstimate estimate;
  if (auto error = pose_from_arrays(msg.position, msg.orientation, estimate.pose)) {
    malformed_.record(channel_name, "invalid estimate", *error);
    return;
  }
  if (!std::isfinite(msg.confidence)) {
    malformed_.record(channel_name, "invalid estimate", "non-finite confidence");
    return;
  }
  estimate.confidence = msg.confidence;
  estimate.held = msg.held;
  // Only the owner's estimates count: a worker that has not yet heard that its object moved (or
  // a merger restart) must not overwrite the owner's.
  if (!workers_.owns(msg.worker_id, msg.object_id)) return;
  // The owner has finished this frame: it will not send an estimate for it or any earlier frame
  // (a lost estimate or a skipped scene), so those frames need not wait.
  workers_.note_progress(msg.object_id, msg.frame_seq);
  frames_.add_estimate(msg.frame_seq, msg.object_id, estimate);  // too late: that frame went out stale
}

void MergerCore::on_heartbeat(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name) {
  heartbeat_t msg;
  if (!decode_message(rbuf, channel_name, msg, malformed_)) return;
  // Ranges first: a held object id beyond kMaxObjectId would push the id counter (retirement
  // reserves the ids through it) to overflow.
  if (msg.worker_id < 0 || msg.worker_id > kMaxWorkerId || msg.object_id < -1 || msg.object_id == 0 ||
      msg.object_id > kMaxObjectId || msg.last_frame_seq < -1) {
    malformed_.record(channel_name, "invalid heartbeat",
                      "worker id " + std::to_string(msg.worker_id) + " (0.." + std::to_string(kMaxWorkerId) +
                          "), object id " + std::to_string(msg.object_id) + " (-1 or 1.." +
                          std::to_string(kMaxObjectId) + ") or last frame " + std::to_string(msg.last_frame_seq) +
                          " (>= -1) out of range");
    return;
  }
  const auto exists = [this](std::int32_t id) { return manager_.objects().count(id) > 0; };
  const std::int64_t seq = frames_.last_finished_seq();
  const auto now = clock_();
  const WorkerPool::Reply reply =
      workers_.heartbeat({msg.worker_id, msg.instance, msg.host, msg.object_id, msg.last_frame_seq}, now, exists);
  if (reply.clash) sink_.note(*reply.clash);
  // A restarted merger asks the (live, unclashing) holder of an object it does not know for it.
  if (msg.object_id >= 0 && !exists(msg.object_id) && workers_.instance_of(msg.worker_id) == msg.instance &&
      !workers_.owner(msg.object_id)) {
    if (auto request = resumer_.held_unknown(msg.worker_id, msg.instance, msg.object_id, now)) {
      sink_.request_model(request->object_id, request->worker_id, request->worker_instance);
    }
  }
  // Every correction is for the worker that heartbeat: its own object's model, or word on an object it
  // holds without owning it.
  for (const auto& correction : reply.corrections) {
    if (correction.kind == WorkerPool::Correction::Kind::kSendModel) {
      send_model(correction.object_id, correction.worker_id, seq, msg.worker_id);
    } else if (!resumer_.pending(correction.object_id, now)) {  // else its report may resume it
      sink_.send_retirement(correction.object_id, seq, msg.worker_id);
      // After a restart of this merger: controllers knew that id as another object (in range: the
      // heartbeat's ids were checked above).
      manager_.reserve_ids_through(correction.object_id);
    }
  }
}

void MergerCore::on_model_report(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name) {
  object_model_t msg;
  if (!decode_message(rbuf, channel_name, msg, malformed_)) return;
  const auto now = clock_();
  if (manager_.objects().count(msg.object_id) > 0) {
    malformed_.record(channel_name, "invalid model report", "object " + std::to_string(msg.object_id) + " exists");
    return;
  }
  auto taken = resumer_.take_report(msg, now);
  if (auto* error = std::get_if<std::string>(&taken)) {
    malformed_.record(channel_name, "invalid model report", *error);
    return;
  }
  ObjectResumer::Resumed& resumed = std::get<ObjectResumer::Resumed>(taken);
  const std::int32_t id = resumed.object.id;
  if (!workers_.resume_owner(id, resumed.worker_id, now)) {
    malformed_.record(channel_name, "invalid model report",
                      "worker " + std::to_string(resumed.worker_id) + " cannot own object " + std::to_string(id) +
                          " (dead, or owns another)");
    return;
  }
  try {
    manager_.resume_object(std::move(resumed.object));
  } catch (const std::invalid_argument& e) {
    workers_.release(id, now);
    malformed_.record(channel_name, "invalid model report", e.what());
    return;
  }
  if (resumed.frame_seq >= 0) workers_.note_progress(id, resumed.frame_seq);
  spdlog::info("object {} resumed from worker {} (model v{}, {} points, last frame {})", id, resumed.worker_id,
               manager_.objects().at(id).version, manager_.objects().at(id).model.cloud.size(), resumed.frame_seq);
}

void MergerCore::send_model(std::int32_t object_id, std::int32_t worker_id, std::int64_t frame_seq,
                            std::int32_t recipient, bool as_edit) {
  claimed_.clear();
  if (claimed_margin_ > 0.f) manager_.claimed_points(object_id, claimed_margin_, claimed_);
  const ManagedObject& object = manager_.objects().at(object_id);
  const std::int64_t instance = workers_.instance_of(worker_id);
  const auto sent = models_sent_.find(object_id);
  std::optional<HeldModel> held;
  if (as_edit && worker_id >= 0 && recipient == worker_id && sent != models_sent_.end() &&
      sent->second.worker_id == worker_id && sent->second.worker_instance == instance &&
      sent->second.version < object.version) {
    held.emplace(HeldModel{sent->second.version, sent->second.cloud});
  }
  sink_.send_model(object, worker_id, instance, frame_seq, claimed_, recipient, held ? &*held : nullptr);
  if (worker_id >= 0 && recipient == worker_id) {
    ModelSent& now_sent = models_sent_[object_id];
    now_sent.worker_id = worker_id;
    now_sent.worker_instance = instance;
    now_sent.version = object.version;
    now_sent.cloud = object.model.cloud;
  }
}

void MergerCore::send_frame_done(std::int64_t frame_seq) {
  frame_done_.frame_seq = frame_seq;
  const auto& objects = manager_.objects();
  frame_done_.objects.resize(objects.size());
  std::size_t k = 0;
  for (const auto& [id, object] : objects) {
    const std::int32_t owner = workers_.owner(id).value_or(-1);
    claimed_.clear();
    if (owner >= 0 && claimed_margin_ > 0.f) manager_.claimed_points(id, claimed_margin_, claimed_);
    frame_done_entry(object, owner, owner >= 0 ? workers_.instance_of(owner) : 0, claimed_, frame_done_.objects[k++]);
  }
  frame_done_.num_objects = static_cast<std::int32_t>(k);
  sink_.send_frame_done(frame_done_);
}

int MergerCore::step() {
  const auto now = clock_();
  workers_.expire(now);
  assign_idle_workers(now);
  // A restarted merger waits for its workers to say what they hold, and for their reports.
  if (resumer_.holds_frames(now)) return 0;
  int finished = 0;
  for (;;) {
    const FrameAssembler::Poll poll = frames_.poll(now, workers_);
    if (!poll.resend_models.empty()) {
      for (const auto& [object_id, worker_id] : poll.resend_models) {
        send_model(object_id, worker_id, frames_.last_finished_seq(), worker_id);
      }
      sink_.resend_scene(*poll.resend_scene);
    }
    if (!poll.due) break;
    finish_frame(now);
    ++finished;
  }
  return finished;
}

// Every object without a live worker goes to the idle worker with the lowest id.
void MergerCore::assign_idle_workers(Clock::time_point now) {
  object_ids_.clear();
  for (const auto& [id, object] : manager_.objects()) object_ids_.push_back(id);
  for (const auto& [object_id, worker_id] : workers_.assign(object_ids_, now)) {
    send_model(object_id, worker_id, frames_.last_finished_seq(), worker_id);
  }
}

void MergerCore::finish_frame(Clock::time_point now) {
  const auto due_at = clock_();
  const FrameAssembler::DueFrame due = frames_.take(workers_);
  const std::int64_t seq = due.scene.frame_seq;
  manager_.set_view(due.scene.view);
  const ObjectManagerFrame& result =
      manager_.process(due.scene.cloud, due.scene.cluster, due.scene.standing_clusters, due.estimates);
  for (const auto& [kept, joined] : result.joined) {
    spdlog::info("object {} joined into object {} (they moved as one rigid body)", joined, kept);
  }
  for (const auto& [split, created] : result.split) {
    spdlog::info("object {} split: its part is object {}", split, created);
  }
  for (const auto& [object, sibling] : result.regrouped) {
    spdlog::info("object {} gave a part to object {} (one convex piece with it)", object, sibling);
  }
  for (const auto& [young, known] : result.reidentified) {
    spdlog::info("object {} is object {} again (re-identified once its model grew)", young, known);
  }
  for (const std::int32_t id : result.retired) {
    const auto joined_away = [id](const auto& j) { return j.second == id; };
    const auto young_reidentified = [id](const auto& r) { return r.first == id; };
    if (std::none_of(result.joined.begin(), result.joined.end(), joined_away) &&
        std::none_of(result.reidentified.begin(), result.reidentified.end(), young_reidentified)) {
      spdlog::info("object {} retired (no support)", id);
    }
    if (const auto owner = workers_.owner(id)) sink_.send_retirement(id, seq, *owner);
    workers_.release(id, now);
    models_sent_.erase(id);
  }
  for (const std::int32_t id : result.created) {
    const bool kept_frame =
        std::find(result.registered.begin(), result.registered.end(), id) != result.registered.end();
    spdlog::info("object {} created at frame {}{}", id, seq,
                 kept_frame ? " (re-identified: its model registered, frame kept)" : "");
  }
  for (const std::int32_t id : result.found_carried) {
    spdlog::info("object {} found again at frame {} away from where it was carried (its model registered)", id, seq);
  }
  assign_idle_workers(now);
  // An owner whose object's model changed gets it (a new object's owner got it on assignment); every
  // worker then gets the frame's end, which stands for the model of this frame where it did not change.
  for (const auto& [object_id, worker_id] : workers_.owners()) {
    const auto sent = models_sent_.find(object_id);
    if (sent == models_sent_.end() || sent->second.worker_id != worker_id ||
        sent->second.worker_instance != workers_.instance_of(worker_id) ||
        sent->second.version != manager_.objects().at(object_id).version) {
      send_model(object_id, worker_id, seq, worker_id, true);
    }
  }
  send_frame_done(seq);
  sink_.publish_frame({due.scene, result, manager_.objects(), due_at});
  frames_.finished(clock_());
  resumer_.close();  // from now on an unknown held object is one this merger retired
}

}  // namespace mfot::service
