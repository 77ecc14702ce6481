#pragma once
// The merger's open frames: each scene waits, in frame order, for the estimates of every object
// that has a live owner (thesis 3.1: segmentation and model update of frame s need all trackers'
// estimates of s), at most the estimate timeout, then is finished with what arrived (a missing
// estimate leaves that object's pose stale).
// Steps, as the merger feeds it what arrives:
//   1. add_scene: scenes join in sequence order; a repeated one (our own re-send coming back) or
//      one of a frame already finished is refused; a scene far older than the last finished one
//      starts a new frame sequence (a restarted capture or replay);
//   2. add_estimate: an owner's estimate of an open frame;
//   3. poll: at start-up the first frame waits (up to the start-up timeout) for the expected
//      workers; then the oldest frame is complete when every owner either sent its estimate or
//      said (by its progress) that it finished the frame without one. A worker that heartbeats
//      well after the scene went out without having finished the frame before it lacks the scene
//      or the previous model: both are sent again, a few times at most. The frame is due when
//      complete, or when the estimate timeout passed since it arrived or since the frame before
//      was finished (trackers need that frame's models first), whichever is later;
//   4. take / finished: the due frame is handed over with its owners' estimates.
// No LCM and no clock of its own: the caller passes the time.

#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <vector>

#include "mfot/object_manager.hpp"
#include "mfot/service/convert.hpp"
#include "mfot/service/worker_pool.hpp"

namespace mfot::service {

struct FrameAssemblerOptions {
  std::chrono::milliseconds estimate_timeout{500};   // merger.estimate_timeout_ms, [1 ms, 600 s]
  int expected_workers = 0;                          // merger.expected_workers, [0, 1000]
  std::chrono::milliseconds startup_timeout{10000};  // merger.startup_timeout_ms, [0, 600 s]
  // A heartbeat arriving this long after a scene, from a worker that has not finished that frame,
  // means the worker never got the scene or the model of the frame before, which it waits for (a
  // worker heartbeats only between frames). Sending both again is harmless: a worker that has
  // them already skips the repeats.
  std::chrono::milliseconds scene_in_flight{50};
  // A scene is sent again at most this often and this many times: a worker that is merely slow
  // skips the repeats; past them the estimate timeout decides.
  std::chrono::milliseconds resend_interval{200};
  int max_resends = 3;
  // A scene this many frames older than the last one finished starts a new frame sequence;
  // anything closer is a late or repeated message.
  std::int64_t sequence_restart = 100;

  // Throws std::invalid_argument naming the field and its range.
  void validate() const;
};

class FrameAssembler {
 public:
  using Clock = std::chrono::steady_clock;

  enum class Arrival {
    kQueued,
    kNewSequence,  // queued, after forgetting the previous sequence
    kRepeated,     // already open (a re-sent scene coming back): ignored
    kLate,         // of a frame already finished: ignored
  };

  // What the oldest open frame needs now.
  struct Poll {
    bool due = false;  // finish it now (take())
    // Workers to send their object's model again, and with them the scene (`resend_scene`).
    std::vector<WorkerPool::Assignment> resend_models;
    const std::vector<std::uint8_t>* resend_scene = nullptr;
    std::int64_t frame_seq = -1;
  };

  struct DueFrame {
    Scene scene;
    std::map<std::int32_t, ObjectEstimate> estimates;  // of the objects owned now
  };

  explicit FrameAssembler(FrameAssemblerOptions options);
  FrameAssembler(const FrameAssembler&) = delete;
  FrameAssembler& operator=(const FrameAssembler&) = delete;

  // Step 1; `message` is the scene as received, to send again to a worker that lost it.
  Arrival add_scene(Scene scene, std::vector<std::uint8_t> message, Clock::time_point now);
  // Step 2; false when the frame is already finished (the estimate came too late).
  bool add_estimate(std::int64_t frame_seq, std::int32_t object_id, const ObjectEstimate& estimate);
  // Step 3.
  Poll poll(Clock::time_point now, const WorkerPool& workers);
  // Step 4: the oldest frame, after poll() said it is due; `finished_at` is when its processing
  // ends (call finished() then), from which the next frame's estimate timeout runs.
  DueFrame take(const WorkerPool& workers);
  void finished(Clock::time_point finished_at) { last_finish_ = finished_at; }

  std::size_t open_frames() const { return pending_.size(); }
  std::int64_t last_finished_seq() const { return last_finished_seq_; }

 private:
  struct PendingScene {
    Scene scene;
    std::vector<std::uint8_t> message;
    Clock::time_point arrived;
    Clock::time_point sent;  // arrival or the last time it was sent again
    int resends = 0;
  };

  FrameAssemblerOptions options_;
  std::deque<PendingScene> pending_;                                          // in sequence order
  std::map<std::int64_t, std::map<std::int32_t, ObjectEstimate>> estimates_;  // frame -> object -> estimate
  Clock::time_point last_finish_{};
  std::int64_t last_finished_seq_ = -1;
  bool started_ = false;
};

}  // namespace mfot::service
