#pragma once
// Per-service health: frame rate, latency percentiles, queue depth, backend and malformed-message
// count, published on MFOT_STATUS once a second and logged.

#include <chrono>
#include <deque>
#include <string>

#include "mfot/service/lcm_util.hpp"

namespace mfot::service {

class StatusReporter {
 public:
  StatusReporter(lcm::LCM& lcm, std::string service, int instance, std::string backend);
  StatusReporter(const StatusReporter&) = delete;
  StatusReporter& operator=(const StatusReporter&) = delete;

  void frame_done(double latency_ms);
  void set_queue_depth(int depth) { queue_depth_ = depth; }
  void set_backend(std::string backend) { backend_ = std::move(backend); }
  void set_message(std::string message) { message_ = std::move(message); }
  MalformedCounter& malformed() { return malformed_; }
  std::int64_t frames() const { return frames_; }

  // Publishes and logs when a second has passed since the last report, then gives the allocator's
  // free pages back (trim_allocator_caches).
  void tick();
  // Publishes and logs now (a state change others should hear at once, e.g. before exiting).
  void publish();

 private:
  using Clock = std::chrono::steady_clock;
  lcm::LCM& lcm_;
  std::string service_;
  int instance_;
  std::string host_;
  std::string backend_;
  std::string message_;
  MalformedCounter malformed_;
  int queue_depth_ = 0;
  std::int64_t frames_ = 0;
  std::int64_t frames_at_last_report_ = 0;
  std::deque<double> latencies_ms_;  // last 300 frames
  Clock::time_point last_report_ = Clock::now();
};

}  // namespace mfot::service
