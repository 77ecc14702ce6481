#include "mfot/capture/pacing.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace mfot::capture {

RateMode parse_rate_mode(const std::string& name) {
  if (name == "realtime") return RateMode::kRealtime;
  if (name == "fast") return RateMode::kFast;
  if (name == "lockstep") return RateMode::kLockstep;
  throw std::invalid_argument("rate '" + name + "' is not one of realtime|fast|lockstep");
}

std::string to_string(RateMode mode) {
  switch (mode) {
    case RateMode::kFast:
      return "fast";
    case RateMode::kLockstep:
      return "lockstep";
    case RateMode::kRealtime:
      break;
  }
  return "realtime";
}

RealtimeSchedule::RealtimeSchedule(double speed, std::chrono::milliseconds max_lag) : speed_(speed), max_lag_(max_lag) {
  if (!(std::isfinite(speed) && speed > 0.0 && speed <= 100.0)) {
    throw std::invalid_argument("RealtimeSchedule speed " + std::to_string(speed) + " is out of range (0, 100]");
  }
  if (max_lag.count() <= 0) throw std::invalid_argument("RealtimeSchedule max_lag must be > 0");
}

RealtimeSchedule::Clock::time_point RealtimeSchedule::due(std::int64_t capture_utime, Clock::time_point now) {
  if (anchor_ && capture_utime < last_capture_utime_) anchor_.reset();
  last_capture_utime_ = capture_utime;
  if (!anchor_) {
    anchor_ = Anchor{capture_utime, now};
    return now;
  }
  const double offset_us = static_cast<double>(capture_utime - anchor_->capture_utime) / speed_;
  const auto due_time =
      anchor_->wall + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double, std::micro>(offset_us));
  if (now - due_time > max_lag_) {
    anchor_ = Anchor{capture_utime, now};
    return now;
  }
  return due_time;
}

LockstepGate::LockstepGate(int window) : window_(window) {
  if (window < 1 || window > service::kMaxLockstepWindow) {
    throw std::invalid_argument("LockstepGate window " + std::to_string(window) + " is out of range [1, " +
                                std::to_string(service::kMaxLockstepWindow) + "]");
  }
}

void LockstepGate::published(std::int64_t seq, Clock::time_point at) { in_flight_.push_back({seq, at}); }

void LockstepGate::answered(std::int64_t frame_seq) {
  while (!in_flight_.empty() && in_flight_.front().seq <= frame_seq) in_flight_.pop_front();
}

void LockstepGate::abandon_oldest() {
  if (!in_flight_.empty()) in_flight_.pop_front();
}

std::optional<std::int64_t> LockstepGate::oldest() const {
  if (in_flight_.empty()) return std::nullopt;
  return in_flight_.front().seq;
}

std::optional<LockstepGate::Clock::time_point> LockstepGate::oldest_published_at() const {
  if (in_flight_.empty()) return std::nullopt;
  return in_flight_.front().published;
}

}  // namespace mfot::capture
