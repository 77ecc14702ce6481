// mfot-pose-client: example controller client. Subscribes to MFOT_POSES (mfot::poses_t) and
// prints one line per object per message, the same lines as scripts/mfot-pose-client:
//
//   frame=<seq> id=<id> x_mm=<x> y_mm=<y> z_mm=<z> roll_deg=<r> pitch_deg=<p> yaw_deg=<y> confidence=<c> stale=<0|1>
//
// Position and orientation are the object -> camera pose (--world: object -> world); roll,
// pitch and yaw are the Z-Y-X Euler angles, R = Rz(yaw) Ry(pitch) Rx(roll).

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <numbers>
#include <string>

#include "mfot/poses_t.hpp"
#include "mfot/service/lcm_util.hpp"

namespace {

struct Rpy {
  double roll, pitch, yaw;  // degrees
};

Rpy rpy_degrees(const double q[4]) {  // w, x, y, z
  const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (norm == 0.0) return {NAN, NAN, NAN};
  const double w = q[0] / norm, x = q[1] / norm, y = q[2] / norm, z = q[3] / norm;
  const double to_deg = 180.0 / std::numbers::pi;
  return {std::atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y)) * to_deg,
          std::asin(std::clamp(2.0 * (w * y - z * x), -1.0, 1.0)) * to_deg,
          std::atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)) * to_deg};
}

void print_poses(const mfot::poses_t& msg, bool world) {
  for (const auto& obj : msg.objects) {
    const double* p = world ? obj.world_position : obj.position;
    const Rpy r = rpy_degrees(world ? obj.world_orientation : obj.orientation);
    std::printf(
        "frame=%lld id=%d x_mm=%.1f y_mm=%.1f z_mm=%.1f roll_deg=%.2f pitch_deg=%.2f yaw_deg=%.2f confidence=%.3f "
        "stale=%d\n",
        static_cast<long long>(msg.frame_seq), obj.id, p[0] * 1000.0, p[1] * 1000.0, p[2] * 1000.0, r.roll, r.pitch,
        r.yaw, static_cast<double>(obj.confidence), obj.stale ? 1 : 0);
  }
  std::fflush(stdout);
}

class PosePrinter {
 public:
  explicit PosePrinter(bool world) : world_(world) {}

  void on_message(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    mfot::poses_t msg;
    if (!mfot::service::decode_message(rbuf, channel, msg, malformed_)) return;
    print_poses(msg, world_);
    ++received_;
  }

  long long received() const { return received_; }
  std::int64_t malformed() const { return malformed_.total(); }

 private:
  bool world_;
  long long received_ = 0;
  mfot::service::MalformedCounter malformed_;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mfot-pose-client: print the tracked object poses on MFOT_POSES"};
  std::string url, channel = mfot::service::channel::kPoses;
  long long count = 0;
  bool world = false;
  app.add_option("--lcm-url", url,
                 "LCM URL (default: $MFOT_LCM_URL, $LCM_DEFAULT_URL or udpm://239.255.76.67:7667?ttl=0)");
  app.add_option("--channel", channel, "channel to subscribe to")->capture_default_str();
  app.add_option("--count", count, "exit after N messages (0: run until Ctrl-C)")->check(CLI::NonNegativeNumber);
  app.add_flag("--world", world, "print the world-frame pose instead of the camera-frame pose");
  CLI11_PARSE(app, argc, argv);

  // stdout carries only pose lines (for piping into a controller); diagnostics go to stderr.
  spdlog::set_default_logger(spdlog::stderr_color_mt("mfot-pose-client"));
  mfot::service::setup_logging("pose-client", 0);
  lcm::LCM lcm(mfot::service::lcm_url(url));
  if (!lcm.good()) {
    std::cerr << "mfot-pose-client: LCM initialisation failed for " << mfot::service::lcm_url(url) << '\n';
    return 2;
  }
  mfot::service::install_signal_handlers();
  PosePrinter printer(world);
  lcm.subscribe(channel, &PosePrinter::on_message, &printer);
  while (!mfot::service::stop_requested() && (count == 0 || printer.received() < count)) {
    if (!mfot::service::handle_for(lcm, 100)) {
      std::cerr << "mfot-pose-client: LCM receive failed\n";
      return 1;
    }
  }
  if (printer.malformed() > 0) std::cerr << "mfot-pose-client: " << printer.malformed() << " undecodable message(s)\n";
  return 0;
}
