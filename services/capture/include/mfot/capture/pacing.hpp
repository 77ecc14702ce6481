#pragma once
// Rate control of the capture service: real-time playback by source timestamps, and lockstep
// (publish the next frame only after the pipeline answered the previous one on MFOT_POSES).
// Both are clock-agnostic state machines; the service loop does the waiting.

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

namespace mfot::capture {

enum class RateMode { kRealtime, kFast, kLockstep };

// "realtime" | "fast" | "lockstep"; anything else throws std::invalid_argument.
RateMode parse_rate_mode(const std::string& name);
std::string to_string(RateMode mode);

// Frame with capture time t is due at anchor_wall + (t - anchor_t) / speed. The schedule
// re-anchors when time goes backwards (a loop, a new recording) or when the publisher fell more
// than max_lag behind, so a stall never turns into a burst of frames.
class RealtimeSchedule {
 public:
  using Clock = std::chrono::steady_clock;

  // speed: playback speed factor, (0, 100]; max_lag: > 0.
  explicit RealtimeSchedule(double speed = 1.0, std::chrono::milliseconds max_lag = std::chrono::milliseconds(500));

  // Wall time at which the frame with this capture time should be published, given `now`.
  Clock::time_point due(std::int64_t capture_utime, Clock::time_point now);
  void reset() { anchor_.reset(); }
  double speed() const { return speed_; }

 private:
  struct Anchor {
    std::int64_t capture_utime;
    Clock::time_point wall;
  };
  double speed_;
  std::chrono::milliseconds max_lag_;
  std::optional<Anchor> anchor_;
  std::int64_t last_capture_utime_ = 0;
};

// Tracks whether the pipeline has finished the last published frame.
class LockstepGate {
 public:
  void published(std::int64_t seq) { waiting_for_ = seq; }
  // A poses_t arrived for frame_seq; frames are answered in order, so a newer seq also counts.
  void answered(std::int64_t frame_seq) {
    if (waiting_for_ && frame_seq >= *waiting_for_) waiting_for_.reset();
  }
  // Gives up on the current frame (timeout).
  void abandon() { waiting_for_.reset(); }
  bool released() const { return !waiting_for_.has_value(); }
  std::optional<std::int64_t> waiting_for() const { return waiting_for_; }

 private:
  std::optional<std::int64_t> waiting_for_;
};

}  // namespace mfot::capture
