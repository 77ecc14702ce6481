#include "mfot/service/status.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <vector>

#include "mfot/percentile.hpp"
#include "mfot/service/message_authenticator.hpp"
#include "mfot/service/service_main.hpp"
#include "mfot/service_status_t.hpp"

namespace mfot::service {

namespace {
constexpr std::size_t kLatencyWindow = 300;

}  // namespace

StatusReporter::StatusReporter(lcm::LCM& lcm, std::string service, int instance, std::string backend)
    : lcm_(lcm), service_(std::move(service)), instance_(instance), host_(host_name()), backend_(std::move(backend)) {}

void StatusReporter::frame_done(double latency_ms) {
  ++frames_;
  latencies_ms_.push_back(latency_ms);
  if (latencies_ms_.size() > kLatencyWindow) latencies_ms_.pop_front();
}

void StatusReporter::tick() {
  if (Clock::now() - last_report_ < std::chrono::seconds(1)) return;
  publish();
  // Once a second, off the frame path: resident memory follows what the service holds now.
  trim_allocator_caches();
}

void StatusReporter::publish() {
  const auto now = Clock::now();
  const double elapsed = std::max(1e-3, std::chrono::duration<double>(now - last_report_).count());
  const std::vector<double> window(latencies_ms_.begin(), latencies_ms_.end());
  service_status_t msg{};
  msg.utime = now_utime();
  msg.service = service_;
  msg.instance = instance_;
  msg.host = host_;
  msg.backend = backend_;
  msg.rate_hz = static_cast<float>(static_cast<double>(frames_ - frames_at_last_report_) / elapsed);
  msg.latency_p50_ms = static_cast<float>(percentile(window, 0.5));
  msg.latency_p99_ms = static_cast<float>(percentile(window, 0.99));
  msg.queue_depth = queue_depth_;
  msg.frames = frames_;
  msg.malformed = malformed_.total();
  if (const MessageAuthenticator* auth = message_authenticator()) {
    const AuthCounts counts = auth->counts();
    msg.foreign = counts.foreign;
    msg.forged = counts.forged;
    msg.replayed = counts.replayed;
  }
  msg.message = message_.empty() ? malformed_.last() : message_;
  publish_message(lcm_, channel::kStatus, msg);
  spdlog::debug(
      "status: {:.1f} Hz, latency p50 {:.2f} ms p99 {:.2f} ms, frames {}, malformed {}, foreign {}, forged {}, "
      "replayed {}, backend {}",
      msg.rate_hz, msg.latency_p50_ms, msg.latency_p99_ms, msg.frames, msg.malformed, msg.foreign, msg.forged,
      msg.replayed, msg.backend);
  frames_at_last_report_ = frames_;
  last_report_ = now;
}

}  // namespace mfot::service
