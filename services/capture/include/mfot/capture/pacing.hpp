#pragma once
// Rate control of the capture service: real-time playback by source timestamps, and lockstep
// (publish the next frame only after the pipeline answered the previous one on MFOT_POSES).
// Both are clock-agnostic state machines; the service loop does the waiting.

#include <chrono>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>

#include "mfot/service/lcm_util.hpp"

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

// Tracks the frames the pipeline has not answered yet, at most `window` of them: the next frame
// may go out while fewer are in flight (window 1: strictly one frame after the other). The pipeline
// stays deterministic for any window (trackers wait for the models of the frame before).
class LockstepGate {
 public:
  using Clock = std::chrono::steady_clock;

  // window in [1, service::kMaxLockstepWindow]; throws std::invalid_argument otherwise.
  explicit LockstepGate(int window = 1);

  void published(std::int64_t seq, Clock::time_point at);
  // A poses_t arrived for frame_seq; frames are answered in order, so it answers every frame up
  // to it as well.
  void answered(std::int64_t frame_seq);
  // Gives up on the oldest frame in flight (its timeout passed).
  void abandon_oldest();
  bool can_publish() const { return static_cast<int>(in_flight_.size()) < window_; }
  bool drained() const { return in_flight_.empty(); }
  // The oldest frame in flight and when it was published.
  std::optional<std::int64_t> oldest() const;
  std::optional<Clock::time_point> oldest_published_at() const;
  int window() const { return window_; }

 private:
  struct InFlight {
    std::int64_t seq;
    Clock::time_point published;
  };
  int window_;
  std::deque<InFlight> in_flight_;  // in publishing order
};

}  // namespace mfot::capture
