#include "mfot/capture/capture_service.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <optional>
#include <string>
#include <variant>

#include "mfot/capture/pacing.hpp"
#include "mfot/capture/source_reader.hpp"
#include "mfot/poses_t.hpp"
#include "mfot/service/frame_codec.hpp"
#include "mfot/service/lcm_util.hpp"
#include "mfot/service/service_main.hpp"
#include "mfot/service/status.hpp"
#include "mfot/service/tum_dataset.hpp"

namespace mfot::capture {
namespace {

using Clock = std::chrono::steady_clock;
using service::channel::kFrame;
using service::channel::kPoses;

double milliseconds_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// A source that has not delivered the next frame for this long is reported as stalled.
constexpr std::chrono::seconds kStallReport{1};

class CaptureService {
 public:
  CaptureService(lcm::LCM& lcm, CaptureSettings settings, std::unique_ptr<FrameSource> source)
      : lcm_(lcm),
        settings_(std::move(settings)),
        source_name_(source->name()),
        scene_yaml_(source->scene_yaml()),
        source_live_(source->live()),
        schedule_(settings_.speed),
        gate_(settings_.lockstep_window),
        status_(lcm, "capture", 0, source->kind()),
        reader_(std::move(source), settings_.start_frame, settings_.loop, settings_.encoding) {
    if (settings_.rate == RateMode::kLockstep) lcm_.subscribe(kPoses, &CaptureService::on_poses, this);
    if (!settings_.groundtruth_dir.empty()) {
      truth_writer_.emplace(settings_.groundtruth_dir);
      truth_writer_->write_scene(scene_yaml_);
    }
  }

  int run() {
    spdlog::info("publishing {} on {} ({} rate{}, depth {}, colour {})", source_name_, kFrame,
                 to_string(settings_.rate),
                 settings_.rate == RateMode::kRealtime   ? fmt::format(", speed {}", settings_.speed)
                 : settings_.rate == RateMode::kLockstep ? fmt::format(", window {}", settings_.lockstep_window)
                                                         : "",
                 service::to_string(settings_.encoding.depth), service::to_string(settings_.encoding.color));
    while (!service::stop_requested()) {
      if (settings_.max_frames > 0 && seq_ >= settings_.max_frames) {
        spdlog::info("published --max-frames {} frames; exiting", settings_.max_frames);
        if (!drain()) break;
        return finish("published --max-frames " + std::to_string(settings_.max_frames) + " frames", 0);
      }
      std::optional<SourceReader::Result> result = wait_for_source();
      if (!result) break;
      if (std::holds_alternative<SourceReader::Ended>(*result)) {
        spdlog::info("{} ended: {} frames published; exiting", source_name_, seq_);
        if (!drain()) break;
        return finish("source ended after " + std::to_string(seq_) + " frames", 0);
      }
      if (const auto* failed = std::get_if<SourceReader::Failed>(&*result)) {
        spdlog::error("{}: {}", source_name_, failed->error);
        return finish("source failed: " + failed->error, 1);
      }
      auto& [item, message, rewound, read_ms] = std::get<SourceReader::Frame>(*result);
      if (rewound) {
        spdlog::info("{} ended after {} frames; looping", source_name_, seq_);
        // Keep capture time increasing across loops: continue one frame period after the last.
        loop_offset_us_ = last_capture_utime_ + frame_period_us_ - item.frame.capture_utime;
      }
      item.frame.capture_utime += loop_offset_us_;
      if (seq_ > 0 && item.frame.capture_utime > last_capture_utime_) {
        frame_period_us_ = item.frame.capture_utime - last_capture_utime_;
      }

      if (settings_.rate == RateMode::kRealtime && !source_live_) {
        if (!wait_until(schedule_.due(item.frame.capture_utime, Clock::now()))) break;
      }
      const auto publish_start = Clock::now();
      publish(item, message);
      status_.frame_done(read_ms + milliseconds_since(publish_start));
      status_.tick();
      if (settings_.rate == RateMode::kLockstep) {
        gate_.published(seq_, Clock::now());
        if (!wait_for_pipeline(false)) break;
      }
      ++seq_;
      // Let other work (status, poses of earlier frames) through without blocking.
      if (!service::handle_for(lcm_, 0)) {
        spdlog::error("LCM receive failed; stopping");
        return 1;
      }
    }
    spdlog::info("stopped: {} frames published", seq_);
    return finish("stopped after " + std::to_string(seq_) + " frames", 0);
  }

 private:
  // Says why the service ends on MFOT_STATUS at once, so the process group hears it.
  int finish(const std::string& why, int exit_code) {
    status_.set_message(why);
    status_.publish();
    return exit_code;
  }

  // The next source result, serving LCM and status meanwhile; a wait longer than kStallReport is
  // reported as a stalled source. nullopt when a stop was requested.
  std::optional<SourceReader::Result> wait_for_source() {
    const auto start = Clock::now();
    auto next_report = start + kStallReport;
    while (!service::stop_requested()) {
      if (auto result = reader_.next(Clock::now() + std::chrono::milliseconds(20))) {
        const double waited_s = std::chrono::duration<double>(Clock::now() - start).count();
        if (waited_s >= std::chrono::duration<double>(kStallReport).count()) {
          spdlog::info("{} resumed after {:.1f} s", source_name_, waited_s);
          status_.set_message(fmt::format("source resumed after a {:.1f} s stall", waited_s));
          status_.publish();
        }
        return result;
      }
      const auto now = Clock::now();
      if (now >= next_report) {
        const double waited_s = std::chrono::duration<double>(now - start).count();
        if (next_report == start + kStallReport) {
          spdlog::warn("{} stalled: no frame for {:.1f} s", source_name_, waited_s);
        }
        status_.set_message(fmt::format("source stalled: no frame for {:.1f} s", waited_s));
        status_.publish();
        next_report = now + kStallReport;
      }
      if (!service::handle_for(lcm_, 0)) {
        spdlog::error("LCM receive failed; stopping");
        return std::nullopt;
      }
      status_.tick();
    }
    return std::nullopt;
  }

  void publish(const SourceFrame& item, frame_t& message) {
    message.seq = seq_;
    message.capture_utime = item.frame.capture_utime;  // after a --loop offset
    message.utime = service::now_utime();
    if (service::publish_message(lcm_, kFrame, message) != 0) spdlog::warn("LCM publish of frame seq {} failed", seq_);
    last_capture_utime_ = item.frame.capture_utime;
    if (!truth_writer_) return;
    if (!item.truth) {
      if (!warned_no_truth_) {
        spdlog::warn("{} has no ground truth for frame {}; nothing written to {}", source_name_, item.index,
                     settings_.groundtruth_dir);
        warned_no_truth_ = true;
      }
      return;
    }
    // Ground truth is keyed by the published sequence number, like poses_t.frame_seq.
    service::GroundTruthFrame truth = *item.truth;
    truth.frame = seq_;
    truth.utime = item.frame.capture_utime;
    try {
      truth_writer_->write(truth);
    } catch (const service::DatasetError& e) {
      throw service::OutputError(e.what());  // the path and the system's reason; exit 3
    }
  }

  // Serves LCM and status until `due`; false when a stop was requested.
  bool wait_until(Clock::time_point due) {
    while (!service::stop_requested()) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(due - Clock::now()).count();
      if (left <= 0) return true;
      if (!service::handle_for(lcm_, static_cast<int>(std::min<long long>(left, 50)))) return false;
      status_.tick();
    }
    return false;
  }

  // Serves LCM until the gate lets the next frame out, or with `all` until every frame in flight
  // is answered; a frame unanswered for lockstep_timeout_s is given up with a warning. False when
  // a stop was requested.
  bool wait_for_pipeline(bool all) {
    const auto timeout =
        std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(settings_.lockstep_timeout_s));
    while (all ? !gate_.drained() : !gate_.can_publish()) {
      if (service::stop_requested()) return false;
      if (Clock::now() - *gate_.oldest_published_at() >= timeout) {
        ++lockstep_timeouts_;
        spdlog::warn("lockstep: no poses for frame seq {} within {} s on {}; continuing ({} timeouts so far)",
                     *gate_.oldest(), settings_.lockstep_timeout_s, kPoses, lockstep_timeouts_);
        status_.set_message("lockstep timeout at seq " + std::to_string(*gate_.oldest()));
        gate_.abandon_oldest();
        continue;
      }
      if (!service::handle_for(lcm_, 20)) {
        spdlog::error("LCM receive failed; stopping");
        return false;
      }
      status_.tick();
    }
    return true;
  }

  // In lockstep, the frames still in flight get their poses before the service ends, so the group
  // has finished every frame when capture exits. False when a stop was requested.
  bool drain() { return settings_.rate != RateMode::kLockstep || wait_for_pipeline(true); }

  void on_poses(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
    poses_t poses;
    if (!service::decode_message(buffer, channel, poses, status_.malformed())) return;
    gate_.answered(poses.frame_seq);
  }

  lcm::LCM& lcm_;
  CaptureSettings settings_;
  std::string source_name_;
  std::string scene_yaml_;  // the source's scene summary, for the ground-truth folder
  bool source_live_;
  RealtimeSchedule schedule_;
  LockstepGate gate_;
  service::StatusReporter status_;
  SourceReader reader_;
  std::optional<service::GroundTruthWriter> truth_writer_;
  std::int64_t seq_ = 0;
  std::int64_t last_capture_utime_ = 0;
  std::int64_t frame_period_us_ = 33333;
  std::int64_t loop_offset_us_ = 0;
  std::int64_t lockstep_timeouts_ = 0;
  bool warned_no_truth_ = false;
};

}  // namespace

int run_capture_service(lcm::LCM& lcm, CaptureSettings settings, std::unique_ptr<FrameSource> source) {
  CaptureService service(lcm, std::move(settings), std::move(source));
  return service.run();
}

int measure_encodings(FrameSource& source, const service::EncodeOptions& base, int count) {
  std::vector<service::Frame> frames;
  while (static_cast<int>(frames.size()) < count) {
    auto item = source.next();
    if (!item) break;
    frames.push_back(std::move(item->frame));
  }
  if (frames.empty()) {
    spdlog::error("{} gave no frames to measure", source.name());
    return 1;
  }
  std::printf("%s: %zu frames of %dx%d\n", source.name().c_str(), frames.size(), frames[0].width, frames[0].height);
  std::printf("%-6s %-7s %10s %10s %10s %9s %9s %8s %7s\n", "depth", "colour", "depth B", "colour B", "frame_t B",
              "encode ms", "decode ms", "mean err", "max err");
  using service::ColorEncoding;
  using service::DepthEncoding;
  for (const auto depth : {DepthEncoding::kRaw, DepthEncoding::kZlib, DepthEncoding::kRvl}) {
    for (const auto color : {ColorEncoding::kRaw, ColorEncoding::kPng, ColorEncoding::kJpeg}) {
      service::EncodeOptions options = base;
      options.depth = depth;
      options.color = color;
      double depth_bytes = 0, color_bytes = 0, message_bytes = 0, encode_ms = 0, decode_ms = 0;
      int max_error = 0;
      double error_sum = 0.0;
      for (const auto& frame : frames) {
        auto start = Clock::now();
        const frame_t message = service::encode_frame(frame, options, 0, source.name(), 0);
        encode_ms += milliseconds_since(start);
        start = Clock::now();
        const service::Frame decoded = service::decode_frame(message);
        decode_ms += milliseconds_since(start);
        depth_bytes += static_cast<double>(message.depth_data.size());
        color_bytes += static_cast<double>(message.color_data.size());
        message_bytes += static_cast<double>(message.getEncodedSize());
        if (decoded.depth_mm != frame.depth_mm) {
          spdlog::error("depth changed in the {} round trip", service::to_string(depth));
          return 1;
        }
        for (std::size_t i = 0; i < frame.color.size(); ++i) {
          const int dr = std::abs(frame.color[i].r - decoded.color[i].r);
          const int dg = std::abs(frame.color[i].g - decoded.color[i].g);
          const int db = std::abs(frame.color[i].b - decoded.color[i].b);
          max_error = std::max({max_error, dr, dg, db});
          error_sum += (dr + dg + db) / (3.0 * static_cast<double>(frame.color.size()));
        }
      }
      const double n = static_cast<double>(frames.size());
      std::printf(
          "%-6s %-7s %10.0f %10.0f %10.0f %9.2f %9.2f %8.2f %7d\n", service::to_string(depth).c_str(),
          (service::to_string(color) + (color == ColorEncoding::kJpeg ? std::to_string(options.jpeg_quality) : ""))
              .c_str(),
          depth_bytes / n, color_bytes / n, message_bytes / n, encode_ms / n, decode_ms / n, error_sum / n, max_error);
    }
  }
  std::printf(
      "(colour error after decoding in 8-bit levels, mean over pixels and channels and the largest; "
      "depth is lossless in every encoding)\n");
  return 0;
}

}  // namespace mfot::capture
