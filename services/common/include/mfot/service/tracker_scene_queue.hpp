#pragma once
// A tracker worker's scenes, in frame order, each released for tracking only once the worker holds
// its object's model of the frame before (thesis 3.3-3.4: the particle filter of frame s scores
// against the model updated with frame s-1). The merger publishes every object's model of the frame it
// last finished (a changed model itself, an unchanged one as its frame_done_t entry) before that frame's poses. In
// lockstep with a window of one frame, scene s is published only after those poses, so the model of s-1 is always there
// first; with a larger window (capture.lockstep_window) scenes run ahead of the models, and this
// queue makes the worker wait for the model, so its results never depend on timing.
// Steps, as the worker feeds it what arrives:
//   1. add_scene: late, repeated and already finished scenes are refused; a scene far older than
//      the newest one starts a new frame sequence (a restarted capture or replay); beyond
//      max_scenes the oldest scene is dropped, and counted as skipped when an object is held;
//   2. model_received / frame_finished: every frame_done_t (and any model) says the merger finished
//      its frame, so scenes up to it are dropped; the worker's own object's model moves the model frame on
//      (an older or repeated one is refused), a new object starts from its model's frame;
//   3. next: the oldest scene s is released when the held model is of the frame before it, i.e.
//      of a frame >= every earlier frame this worker tracked, skipped or knows finished (s - 1
//      when no scene was lost). A scene whose previous frame never came waits up to gap_wait for
//      it (the merger sends a lost scene again) before it goes ahead of it; a model that never
//      comes is given up after model_wait (liveness), counted as a fallback. The merger's own
//      estimate timeout normally comes first (it finishes the frame without the estimate and
//      sends the model), so model_wait is generous: a slow but healthy tracker elsewhere in the
//      group must never reach it. In a healthy run no scene is missing and nothing waits on time.
// No LCM and no clock of its own: the caller passes the time.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>

#include "mfot/service/convert.hpp"

namespace mfot::service {

struct TrackerSceneQueueOptions {
  std::size_t max_scenes = 8;                  // queued scenes, [1, 64]; >= capture.lockstep_window
  std::chrono::milliseconds model_wait{5000};  // wait for the previous frame's model, [1 ms, 600 s]
  // Wait for a scene missing before the oldest one, [0, 600 s] (at most model_wait takes effect):
  // longer than the merger takes to send a lost scene again (kSceneResendInterval and a heartbeat,
  // 200-300 ms).
  std::chrono::milliseconds gap_wait{500};
  // A scene this many frames older than the newest one known starts a new frame sequence.
  std::int64_t sequence_restart = 100;

  // Throws std::invalid_argument naming the field and its range.
  void validate() const;
};

class TrackerSceneQueue {
 public:
  using Clock = std::chrono::steady_clock;

  enum class Arrival {
    kQueued,
    kNewSequence,  // queued, after forgetting the previous sequence's frames
    kRefused,      // late, repeated or already finished by the merger
  };

  explicit TrackerSceneQueue(TrackerSceneQueueOptions options = {});
  TrackerSceneQueue(const TrackerSceneQueue&) = delete;
  TrackerSceneQueue& operator=(const TrackerSceneQueue&) = delete;

  Arrival add_scene(Scene scene);

  // Whether a model of `object_id` of frame `frame_seq` assigned to this worker is to be taken:
  // not when it is not newer than the one held for the same object (reordered or repeated), nor
  // a late one of a frame sequence that has ended.
  bool accepts_model(std::int32_t object_id, std::int64_t frame_seq) const;
  // The worker took that model.
  void model_received(std::int32_t object_id, std::int64_t frame_seq);
  // A frame_done_t, or a model not taken (another worker's object, a retirement): the merger finished frame_seq.
  void frame_finished(std::int64_t frame_seq);
  // The object was retired or moved to another worker; scenes stay queued for the next one.
  void object_dropped();

  // The scene to track now, if any (see step 3).
  std::optional<Scene> next(Clock::time_point now);

  // The last frame this worker finished for its object (tracked, or skipped): what its heartbeat
  // reports, so the merger does not wait for an estimate that will not come. -1 = none.
  std::int64_t last_done() const { return done_; }
  std::size_t size() const { return scenes_.size(); }
  std::int64_t skipped() const { return skipped_; }          // scenes dropped beyond max_scenes while holding an object
  std::int64_t fallbacks() const { return fallbacks_; }      // scenes released after model_wait without their model
  std::int64_t gaps_passed() const { return gaps_passed_; }  // scenes released after gap_wait ahead of a lost one

 private:
  void drop_finished();
  std::int64_t newest_known() const;
  bool from_ended_sequence(std::int64_t frame_seq) const;

  TrackerSceneQueueOptions options_;
  std::deque<Scene> scenes_;  // ascending frame_seq, all > done_ and > finished_
  std::int32_t object_id_ = -1;
  std::int64_t model_frame_ = -1;  // frame of the held model (-1: none yet in this sequence)
  std::int64_t done_ = -1;
  std::int64_t finished_ = -1;     // the newest frame the merger has finished
  bool restarted_ = false;         // a new sequence began: an old one's late models are ignored
  std::int64_t blocked_seq_ = -1;  // the scene waiting for its model, and since when
  Clock::time_point blocked_since_{};
  std::int64_t skipped_ = 0;
  std::int64_t fallbacks_ = 0;
  std::int64_t gaps_passed_ = 0;
};

}  // namespace mfot::service
