#include "mfot/service/frame_assembler.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <stdexcept>
#include <string>

namespace mfot::service {

namespace {
void check_ms(const char* name, std::chrono::milliseconds value, long long lo, long long hi) {
  if (value.count() < lo || value.count() > hi) {
    throw std::invalid_argument(std::string(name) + " must be in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                                "] ms, got " + std::to_string(value.count()));
  }
}
}  // namespace

void FrameAssemblerOptions::validate() const {
  check_ms("estimate_timeout", estimate_timeout, 1, 600000);
  check_ms("startup_timeout", startup_timeout, 0, 600000);
  check_ms("scene_in_flight", scene_in_flight, 0, 600000);
  check_ms("resend_interval", resend_interval, 0, 600000);
  if (expected_workers < 0 || expected_workers > 1000) {
    throw std::invalid_argument("expected_workers must be in [0, 1000], got " + std::to_string(expected_workers));
  }
  if (max_resends < 0) throw std::invalid_argument("max_resends must be >= 0, got " + std::to_string(max_resends));
  if (sequence_restart < 1) {
    throw std::invalid_argument("sequence_restart must be >= 1, got " + std::to_string(sequence_restart));
  }
}

FrameAssembler::FrameAssembler(FrameAssemblerOptions options) : options_(options) { options_.validate(); }

FrameAssembler::Arrival FrameAssembler::add_scene(Scene scene, std::vector<std::uint8_t> message,
                                                  Clock::time_point now) {
  Arrival arrival = Arrival::kQueued;
  if (scene.frame_seq + options_.sequence_restart < last_finished_seq_) {
    last_finished_seq_ = -1;
    estimates_.clear();
    arrival = Arrival::kNewSequence;
  }
  // A reordered scene joins the queue in sequence order.
  const auto at = std::find_if(pending_.begin(), pending_.end(),
                               [&](const PendingScene& p) { return p.scene.frame_seq >= scene.frame_seq; });
  if (at != pending_.end() && at->scene.frame_seq == scene.frame_seq) return Arrival::kRepeated;
  if (scene.frame_seq <= last_finished_seq_) return Arrival::kLate;
  pending_.insert(at, PendingScene{std::move(scene), std::move(message), now, now, 0});
  return arrival;
}

bool FrameAssembler::add_estimate(std::int64_t frame_seq, std::int32_t object_id, const ObjectEstimate& estimate) {
  if (frame_seq <= last_finished_seq_) return false;
  estimates_[frame_seq][object_id] = estimate;
  return true;
}

FrameAssembler::Poll FrameAssembler::poll(Clock::time_point now, const WorkerPool& workers) {
  Poll poll;
  if (pending_.empty()) return poll;
  PendingScene& next = pending_.front();
  poll.frame_seq = next.scene.frame_seq;
  if (!started_) {
    if (workers.alive_count() < options_.expected_workers && now - next.arrived < options_.startup_timeout) {
      return poll;
    }
    started_ = true;
  }
  const std::int64_t seq = next.scene.frame_seq;
  const auto got = estimates_.find(seq);
  bool complete = true;
  std::vector<WorkerPool::Assignment> lagging;
  // Trackers could work on this frame only once the frame before was finished.
  const auto sent = std::max(next.sent, last_finish_);
  for (const auto& [object_id, worker_id] : workers.owners()) {
    if (got != estimates_.end() && got->second.count(object_id)) continue;
    const auto progress = workers.progress(object_id);
    if (progress && *progress >= seq) continue;  // lost, or skipped
    complete = false;
    const WorkerPool::Worker& w = workers.workers().at(worker_id);
    if (w.last_frame_seq < seq && w.last_seen > sent + options_.scene_in_flight &&
        now - sent > options_.resend_interval) {
      lagging.push_back({object_id, worker_id});
    }
  }
  if (!complete && !lagging.empty() && next.resends < options_.max_resends) {
    spdlog::info("a worker did not get the scene of frame {} or the model before it; sending them again", seq);
    poll.resend_models = std::move(lagging);
    poll.resend_scene = &next.message;
    next.sent = now;
    ++next.resends;
  }
  const auto waiting_since = std::max(next.arrived, last_finish_);  // not sent: re-sends do not extend it
  poll.due = complete || now - waiting_since > options_.estimate_timeout;
  return poll;
}

FrameAssembler::DueFrame FrameAssembler::take(const WorkerPool& workers) {
  if (pending_.empty()) throw std::logic_error("FrameAssembler::take without an open frame");
  DueFrame due;
  due.scene = std::move(pending_.front().scene);
  pending_.pop_front();
  const std::int64_t seq = due.scene.frame_seq;
  const auto got = estimates_.find(seq);
  if (got != estimates_.end()) {
    for (const auto& [object_id, estimate] : got->second) {
      if (workers.owner(object_id)) due.estimates.emplace(object_id, estimate);
    }
  }
  last_finished_seq_ = seq;
  estimates_.erase(estimates_.begin(), estimates_.upper_bound(seq));
  return due;
}

}  // namespace mfot::service
