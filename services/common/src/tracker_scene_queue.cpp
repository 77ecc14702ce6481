#include "mfot/service/tracker_scene_queue.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace mfot::service {

void TrackerSceneQueueOptions::validate() const {
  if (max_scenes < 1 || max_scenes > 64) {
    throw std::invalid_argument("TrackerSceneQueueOptions.max_scenes must be in [1, 64], got " +
                                std::to_string(max_scenes));
  }
  if (model_wait.count() < 1 || model_wait.count() > 600000) {
    throw std::invalid_argument("TrackerSceneQueueOptions.model_wait must be in [1, 600000] ms, got " +
                                std::to_string(model_wait.count()));
  }
  if (gap_wait.count() < 0 || gap_wait.count() > 600000) {
    throw std::invalid_argument("TrackerSceneQueueOptions.gap_wait must be in [0, 600000] ms, got " +
                                std::to_string(gap_wait.count()) + " ms");
  }
  if (sequence_restart < 1) throw std::invalid_argument("TrackerSceneQueueOptions.sequence_restart must be >= 1");
}

TrackerSceneQueue::TrackerSceneQueue(TrackerSceneQueueOptions options) : options_(options) { options_.validate(); }

std::int64_t TrackerSceneQueue::newest_known() const {
  return std::max({done_, finished_, scenes_.empty() ? std::int64_t{-1} : scenes_.back().frame_seq});
}

TrackerSceneQueue::Arrival TrackerSceneQueue::add_scene(Scene scene) {
  const std::int64_t seq = scene.frame_seq;
  Arrival arrival = Arrival::kQueued;
  if (seq + options_.sequence_restart < newest_known()) {
    scenes_.clear();
    done_ = -1;
    finished_ = -1;
    model_frame_ = -1;  // the model is kept; the new sequence's frame 0 is tracked with it
    blocked_seq_ = -1;
    restarted_ = true;
    arrival = Arrival::kNewSequence;
  }
  if (seq <= done_ || seq <= finished_) return Arrival::kRefused;
  const auto at = std::lower_bound(scenes_.begin(), scenes_.end(), seq,
                                   [](const Scene& queued, std::int64_t s) { return queued.frame_seq < s; });
  if (at != scenes_.end() && at->frame_seq == seq) return Arrival::kRefused;
  scenes_.insert(at, std::move(scene));
  if (scenes_.size() > options_.max_scenes) {
    // The merger will not get this frame's estimate: say it is done, so it does not wait for it.
    if (object_id_ >= 0) {
      done_ = std::max(done_, scenes_.front().frame_seq);
      ++skipped_;
    }
    scenes_.pop_front();
  }
  return arrival;
}

// After a new sequence began, a frame far ahead of every frame of it is a late one of the old
// sequence; the merger sends the model again with the new sequence's next frame.
bool TrackerSceneQueue::from_ended_sequence(std::int64_t frame_seq) const {
  return restarted_ && frame_seq > newest_known() + options_.sequence_restart;
}

bool TrackerSceneQueue::accepts_model(std::int32_t object_id, std::int64_t frame_seq) const {
  if (from_ended_sequence(frame_seq)) return false;
  return object_id != object_id_ || frame_seq > model_frame_;
}

void TrackerSceneQueue::model_received(std::int32_t object_id, std::int64_t frame_seq) {
  if (!accepts_model(object_id, frame_seq)) return;
  if (object_id != object_id_) {
    object_id_ = object_id;
    done_ = std::max(done_, frame_seq);  // nothing up to the model's frame is this object's to track
    blocked_seq_ = -1;
  }
  model_frame_ = frame_seq;
  frame_finished(frame_seq);
}

void TrackerSceneQueue::frame_finished(std::int64_t frame_seq) {
  if (from_ended_sequence(frame_seq)) return;
  finished_ = std::max(finished_, frame_seq);
  drop_finished();
}

void TrackerSceneQueue::object_dropped() {
  object_id_ = -1;
  model_frame_ = -1;
  blocked_seq_ = -1;
}

void TrackerSceneQueue::drop_finished() {
  while (!scenes_.empty() && (scenes_.front().frame_seq <= finished_ || scenes_.front().frame_seq <= done_)) {
    scenes_.pop_front();
  }
}

std::optional<Scene> TrackerSceneQueue::next(Clock::time_point now) {
  drop_finished();
  if (object_id_ < 0 || scenes_.empty()) return std::nullopt;
  const std::int64_t seq = scenes_.front().frame_seq;
  const std::int64_t previous = std::max(done_, finished_);  // the frame before s, as far as this worker knows
  const bool model_ready = model_frame_ >= previous;
  const bool gap = previous < seq - 1;
  if (!model_ready || gap) {
    if (blocked_seq_ != seq) {
      blocked_seq_ = seq;
      blocked_since_ = now;
    }
    const auto waited = now - blocked_since_;
    if (model_ready && waited >= options_.gap_wait) {
      ++gaps_passed_;
    } else if (waited >= options_.model_wait) {
      ++fallbacks_;
    } else {
      return std::nullopt;
    }
  }
  blocked_seq_ = -1;
  Scene scene = std::move(scenes_.front());
  scenes_.pop_front();
  done_ = seq;
  return scene;
}

}  // namespace mfot::service
