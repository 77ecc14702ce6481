#include "mfot/service/lcm_util.hpp"

#include <spdlog/spdlog.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdlib>

namespace mfot::service {

std::string lcm_url(const std::string& configured) {
  if (!configured.empty()) return configured;
  if (const char* env = std::getenv("LCM_DEFAULT_URL"); env != nullptr && *env != '\0') return env;
  return kDefaultLcmUrl;
}

std::int64_t now_utime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

void MalformedCounter::record(const std::string& channel, const std::string& kind, const std::string& detail) {
  std::lock_guard lock(mutex_);
  const auto n = ++counts_[{channel, kind}];
  ++total_;
  last_ = channel + ": " + kind + ": " + detail;
  if (n == 1) {
    spdlog::warn("malformed message on {} ({}): {}; dropped (further ones of this kind are only counted)", channel,
                 kind, detail);
  }
}

std::int64_t MalformedCounter::total() const {
  std::lock_guard lock(mutex_);
  return total_;
}

std::string MalformedCounter::last() const {
  std::lock_guard lock(mutex_);
  return last_;
}

namespace {
std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop.store(true); }
}  // namespace

void install_signal_handlers() {
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
}
bool stop_requested() { return g_stop.load(); }
void request_stop() { g_stop.store(true); }

bool handle_for(lcm::LCM& lcm, int timeout_ms) { return lcm.handleTimeout(timeout_ms) >= 0; }

void setup_logging(const std::string& service, int instance) {
  spdlog::set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ [" + service + "/" + std::to_string(instance) + "] %v");
  if (const char* level = std::getenv("MFOT_LOG_LEVEL"); level != nullptr) {
    spdlog::set_level(spdlog::level::from_str(level));
  }
}

}  // namespace mfot::service
