// mfot-replay: replays the frames of a recorded lcm log into the pipeline. In lockstep (the
// default) at most --lockstep-window frames are out without the merger's poses (1: the next frame
// only after the previous frame's poses), so a replay reproduces the recorded results bit for bit;
// --rate realtime keeps the recorded timing and --rate fast publishes as fast as it can.

#include "mfot/frame_t.hpp"
#include "mfot/poses_t.hpp"
#include "mfot/service/lcm_util.hpp"
#include "mfot/service/service_main.hpp"
#include "mfot/service/status.hpp"

#include <CLI/CLI.hpp>
#include <lcm/lcm-cpp.hpp>
#include <spdlog/spdlog.h>

#include <chrono>
#include <deque>
#include <thread>

namespace mfot::service {
namespace {

using Clock = std::chrono::steady_clock;

class LockstepGate {
 public:
  explicit LockstepGate(lcm::LCM& lcm, MalformedCounter& malformed) : lcm_(lcm), malformed_(malformed) {
    lcm_.subscribe(channel::kPoses, &LockstepGate::on_poses, this);
  }
  // Waits until poses for `seq` arrive; false on timeout or stop.
  bool wait_for(std::int64_t seq, int timeout_ms) {
    const auto deadline = Clock::now() + std::chrono::milliseconds(timeout_ms);
    while (last_seq_ < seq && !stop_requested()) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left <= 0) return false;
      lcm_.handleTimeout(static_cast<int>(std::min<long long>(left, 50)));
    }
    return last_seq_ >= seq;
  }
  void poll() {
    while (lcm_.handleTimeout(0) > 0) {
    }
  }

 private:
  void on_poses(const lcm::ReceiveBuffer* rbuf, const std::string& chan) {
    poses_t msg;
    if (decode_message(rbuf, chan, msg, malformed_)) last_seq_ = std::max(last_seq_, msg.frame_seq);
  }
  lcm::LCM& lcm_;
  MalformedCounter& malformed_;
  std::int64_t last_seq_ = -1;
};

// Waits until at most `keep` frames are in flight, giving up on a frame after timeout_ms; false
// when a stop was requested.
bool wait_for_oldest(LockstepGate& gate, std::deque<std::int64_t>& in_flight, std::size_t keep, int timeout_ms) {
  while (in_flight.size() > keep) {
    if (!gate.wait_for(in_flight.front(), timeout_ms)) {
      if (stop_requested()) return false;
      spdlog::warn("no poses for frame {} within {} ms; continuing", in_flight.front(), timeout_ms);
    }
    in_flight.pop_front();
  }
  gate.poll();
  return true;
}

int replay(const std::string& log_path, const std::string& url, const std::string& rate, int timeout_ms,
           std::int64_t max_frames, int window) {
  lcm::LogFile log(log_path, "r");
  if (!log.good()) {
    spdlog::error("{}: cannot open lcm log", log_path);
    return 1;
  }
  lcm::LCM lcm(url);
  if (!lcm.good()) {
    spdlog::error("cannot open LCM at {}", url);
    return 1;
  }
  StatusReporter status(lcm, "replay", 0, "lcmlog");
  LockstepGate gate(lcm, status.malformed());
  std::int64_t published = 0;
  std::int64_t first_log_utime = -1;
  std::deque<std::int64_t> in_flight;  // lockstep: frames published without poses yet
  const auto start = Clock::now();
  while (!stop_requested() && (max_frames <= 0 || published < max_frames)) {
    const lcm::LogEvent* event = log.readNextEvent();
    if (event == nullptr) break;
    if (event->channel != channel::kFrame) continue;
    frame_t frame;
    if (frame.decode(event->data, 0, event->datalen) < 0) {
      status.malformed().record(event->channel, "undecodable", "log event " + std::to_string(event->eventnum));
      continue;
    }
    if (rate == "realtime") {
      if (first_log_utime < 0) first_log_utime = event->timestamp;
      std::this_thread::sleep_until(start + std::chrono::microseconds(event->timestamp - first_log_utime));
    }
    const auto t0 = Clock::now();
    lcm.publish(channel::kFrame, event->data, static_cast<unsigned>(event->datalen));
    ++published;
    if (rate == "lockstep") {
      in_flight.push_back(frame.seq);
      if (!wait_for_oldest(gate, in_flight, static_cast<std::size_t>(window) - 1, timeout_ms)) break;
    } else {
      gate.poll();
    }
    status.frame_done(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    status.tick();
  }
  // The frames still in flight get their poses before the replay ends.
  if (rate == "lockstep" && !stop_requested()) wait_for_oldest(gate, in_flight, 0, timeout_ms);
  spdlog::info("replayed {} frames from {}", published, log_path);
  // Say it at once, so the process group hears why the source ended.
  status.set_message("log ended after " + std::to_string(published) + " frames");
  status.publish();
  return 0;
}

}  // namespace
}  // namespace mfot::service

int main(int argc, char** argv) {
  using namespace mfot::service;
  CLI::App app{"mfot-replay: publish a recorded log's frames (lockstep by default)"};
  std::string log_path;
  std::string lcm_url_arg;
  std::string rate = "lockstep";
  int timeout_ms = 10000;
  std::int64_t max_frames = 0;
  int window = kDefaultLockstepWindow;
  app.add_option("log", log_path, "lcm log recorded by the process group")->required()->check(CLI::ExistingFile);
  app.add_option("--lcm-url", lcm_url_arg, "LCM provider URL (default: $LCM_DEFAULT_URL or udpm ttl=0)");
  app.add_option("--rate", rate, "lockstep | realtime | fast")->check(CLI::IsMember({"lockstep", "realtime", "fast"}));
  app.add_option("--lockstep-timeout-ms", timeout_ms, "wait at most this long for a frame's poses")
      ->check(CLI::Range(1, 3600000));
  app.add_option("--lockstep-window", window, "lockstep: frames out without their poses (capture.lockstep_window)")
      ->check(CLI::Range(1, kMaxLockstepWindow));
  app.add_option("--max-frames", max_frames, "stop after this many frames (0: all)")->check(CLI::NonNegativeNumber);
  CLI11_PARSE(app, argc, argv);
  setup_logging("replay", 0);
  install_signal_handlers();
  return run_service_main([&] { return replay(log_path, lcm_url(lcm_url_arg), rate, timeout_ms, max_frames, window); });
}
