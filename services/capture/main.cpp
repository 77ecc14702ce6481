// mfot-capture: the pipeline's input. Reads registered RGB-D frames from a source (the live
// simulator, a TUM RGB-D folder, an OpenNI2 .oni recording or a live OpenNI2 camera), encodes
// them (depth raw/zlib, colour raw/JPEG/PNG) and publishes frame_t on MFOT_FRAME, paced in real
// time by the source timestamps, as fast as possible, or in lockstep with the pipeline (at most
// capture.lockstep_window frames whose poses_t has not arrived on MFOT_POSES; window 1: the next
// frame only after the previous frame's poses). Ground truth of the
// simulator (or of a rendered TUM folder) is written to --groundtruth-dir for offline scoring.
// Section `capture` of the config; the command line overrides it.
//
// The source is read and its images encoded on their own thread one frame ahead (in lockstep the
// next frame is ready to go the moment the poses arrive), so a source that stalls (a camera that
// stops delivering, a file that cannot be read) never silences the service: it keeps reporting
// on MFOT_STATUS that it waits for its source, and carries on when frames come again. When a
// finite source ends, that is reported on MFOT_STATUS before the service exits with 0.
//
// --measure-encodings N prints bytes per frame of every encoding for the first N frames of the
// source and exits (no LCM).

#include "mfot/capture/capture_settings.hpp"
#include "mfot/poses_t.hpp"
#include "mfot/service/config.hpp"
#include "mfot/service/frame_codec.hpp"
#include "mfot/service/lcm_util.hpp"
#include "mfot/service/status.hpp"
#include "mfot/service/tum_dataset.hpp"

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <sys/resource.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <variant>

namespace mfot::capture {
namespace {

using Clock = std::chrono::steady_clock;
using service::channel::kFrame;
using service::channel::kPoses;

double milliseconds_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// The reader thread runs this much nicer than the service (Linux niceness is per thread): reading
// ahead (for the simulator: rendering, ~20 ms of CPU a frame) must not take the CPU from the
// pipeline working on the frame already published, whose poses the frame-to-pose latency waits for.
constexpr int kReaderNiceIncrement = 5;

// A source that has not delivered the next frame for this long is reported as stalled.
constexpr std::chrono::seconds kStallReport{1};

// Reads the source and encodes its images on its own thread, one frame ahead of the publisher.
// Seeking to the start frame and rewinding for --loop happen there too, so every source call
// stays on one thread.
class SourceReader {
 public:
  struct Frame {
    SourceFrame item;
    frame_t message;       // the encoded images; the publisher sets seq, utime and capture_utime
    bool rewound = false;  // the first frame after a --loop rewind
    double read_ms = 0.0;  // reading and encoding
  };
  struct Ended {};
  struct Failed {
    std::string error;
  };
  using Result = std::variant<Frame, Ended, Failed>;

  SourceReader(std::unique_ptr<FrameSource> source, std::int64_t start_frame, bool loop,
               service::EncodeOptions encoding)
      : state_(std::make_shared<State>()) {
    state_->source = std::move(source);
    // The thread shares the state, so a thread still blocked in the source when the service
    // exits never touches freed memory.
    thread_ = std::thread(
        [state = state_, start_frame, loop, encoding] { read_all(*state, start_frame, loop, encoding); });
  }
  SourceReader(const SourceReader&) = delete;
  SourceReader& operator=(const SourceReader&) = delete;

  ~SourceReader() {
    std::unique_lock lock(state_->mutex);
    state_->stop = true;
    state_->changed.notify_all();
    if (state_->changed.wait_for(lock, std::chrono::seconds(2), [&] { return state_->done; })) {
      lock.unlock();
      thread_.join();
    } else {
      spdlog::warn("{} is still blocked in a read; exiting without it", state_->name);
      thread_.detach();
    }
  }

  // The next result, or nullopt when none came before `deadline`.
  std::optional<Result> next(Clock::time_point deadline) {
    std::unique_lock lock(state_->mutex);
    if (!state_->changed.wait_until(lock, deadline, [&] { return state_->result.has_value(); })) return std::nullopt;
    Result result = std::move(*state_->result);
    state_->result.reset();
    state_->changed.notify_all();
    return result;
  }

 private:
  struct State {
    std::unique_ptr<FrameSource> source;
    std::string name;
    std::mutex mutex;
    std::condition_variable changed;
    std::optional<Result> result;  // handed to the publisher, at most one at a time
    bool stop = false;
    bool done = false;
  };

  static void read_all(State& state, std::int64_t start_frame, bool loop, const service::EncodeOptions& encoding) {
    FrameSource& source = *state.source;
    const std::string name = source.name();
    lower_thread_priority(name);
    {
      std::lock_guard lock(state.mutex);
      state.name = name;
    }
    const auto hand_over = [&state](Result result) {
      std::unique_lock lock(state.mutex);
      state.changed.wait(lock, [&] { return state.stop || !state.result.has_value(); });
      if (state.stop) return false;
      state.result = std::move(result);
      state.changed.notify_all();
      return true;
    };
    try {
      if (start_frame > 0) source.seek(start_frame);
      bool rewound = false;
      for (;;) {
        const auto start = Clock::now();
        std::optional<SourceFrame> item = source.next();
        if (!item) {
          if (service::stop_requested()) break;
          if (loop && !rewound && source.rewind()) {
            if (start_frame > 0) source.seek(start_frame);
            rewound = true;
            continue;
          }
          hand_over(Ended{});
          break;
        }
        frame_t message = service::encode_frame(item->frame, encoding, 0, name, 0);
        if (!hand_over(Frame{std::move(*item), std::move(message), rewound, milliseconds_since(start)})) break;
        rewound = false;
      }
    } catch (const std::exception& e) {
      hand_over(Failed{e.what()});
    }
    std::lock_guard lock(state.mutex);
    state.done = true;
    state.changed.notify_all();
  }

  static void lower_thread_priority(const std::string& name) {
    errno = 0;
    const int nice = getpriority(PRIO_PROCESS, 0);  // 0: this thread on Linux
    if ((nice == -1 && errno != 0) || setpriority(PRIO_PROCESS, 0, nice + kReaderNiceIncrement) != 0) {
      spdlog::warn("{}: cannot lower the reader thread's priority ({}); it competes with the pipeline",
                   name, std::strerror(errno));
    }
  }

  std::shared_ptr<State> state_;
  std::thread thread_;
};

class CaptureService {
 public:
  CaptureService(lcm::LCM& lcm, CaptureSettings settings, std::unique_ptr<FrameSource> source)
      : lcm_(lcm),
        settings_(std::move(settings)),
        source_name_(source->name()),
        source_live_(source->live()),
        schedule_(settings_.speed),
        gate_(settings_.lockstep_window),
        status_(lcm, "capture", 0, source->kind()),
        reader_(std::move(source), settings_.start_frame, settings_.loop, settings_.encoding) {
    if (settings_.rate == RateMode::kLockstep) lcm_.subscribe(kPoses, &CaptureService::on_poses, this);
    if (!settings_.groundtruth_dir.empty()) truth_writer_.emplace(settings_.groundtruth_dir);
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
    if (lcm_.publish(kFrame, &message) != 0) spdlog::warn("LCM publish of frame seq {} failed", seq_);
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
    truth_writer_->write(truth);
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

// Bytes per frame and codec time of every encoding over the first `count` frames.
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
      std::printf("%-6s %-7s %10.0f %10.0f %10.0f %9.2f %9.2f %8.2f %7d\n", service::to_string(depth).c_str(),
                  (service::to_string(color) + (color == ColorEncoding::kJpeg ? std::to_string(options.jpeg_quality) : ""))
                      .c_str(),
                  depth_bytes / n, color_bytes / n, message_bytes / n, encode_ms / n, decode_ms / n, error_sum / n,
                  max_error);
    }
  }
  std::printf("(colour error after decoding in 8-bit levels, mean over pixels and channels and the largest; "
              "depth is lossless in every encoding)\n");
  return 0;
}

}  // namespace
}  // namespace mfot::capture

int main(int argc, char** argv) {
  using namespace mfot::capture;
  using namespace mfot::service;
  CLI::App app{"mfot-capture: publish RGB-D frames (frame_t) on MFOT_FRAME from the simulator, a TUM folder, "
               "an .oni recording or an OpenNI2 camera"};
  std::string config_path = "configs/default.yaml";
  std::string lcm_url_arg;
  CaptureSettings cli;
  std::string rate, depth_encoding, color_encoding;
  int measure = 0;
  app.add_option("--config", config_path, "YAML config (section `capture`)");
  app.add_option("--lcm-url", lcm_url_arg, "LCM provider URL (default: $LCM_DEFAULT_URL or udpm ttl=0)");
  auto* o_source = app.add_option("--source", cli.source, "sim | tum | oni | openni2")
                       ->check(CLI::IsMember({"sim", "tum", "oni", "openni2"}));
  auto* o_scenario = app.add_option("--scenario", cli.scenario, "sim scenario: stack | contact | rotate | static | random");
  auto* o_seed = app.add_option("--seed", cli.seed, "sim: scenario and sensor-noise seed");
  auto* o_sim_frames = app.add_option("--sim-frames", cli.sim_frames, "sim: frames to render, 0 = the scenario's length");
  auto* o_folder = app.add_option("--folder", cli.tum_folder, "tum: the TUM RGB-D folder");
  auto* o_depth_scale = app.add_option("--depth-scale", cli.depth_scale, "tum: depth PNG units per metre (TUM: 5000)");
  auto* o_oni = app.add_option("--oni", cli.oni_file, "oni: the .oni recording");
  auto* o_uri = app.add_option("--device-uri", cli.device_uri, "openni2: device URI (default: first device)");
  auto* o_rate = app.add_option("--rate", rate, "realtime | fast | lockstep")
                     ->check(CLI::IsMember({"realtime", "fast", "lockstep"}));
  auto* o_speed = app.add_option("--speed", cli.speed, "realtime playback speed factor (0, 100]");
  auto* o_timeout = app.add_option("--lockstep-timeout", cli.lockstep_timeout_s,
                                   "lockstep: seconds to wait for the poses of a frame before warning and moving on");
  auto* o_window = app.add_option("--lockstep-window", cli.lockstep_window,
                                  "lockstep: frames in flight without poses [1, 8]");
  auto* o_max = app.add_option("--max-frames", cli.max_frames, "frames to publish, 0 = unlimited");
  auto* o_start = app.add_option("--start-frame", cli.start_frame, "first source frame");
  auto* o_loop = app.add_flag("--loop", cli.loop, "restart a finite source at its end");
  auto* o_truth = app.add_option("--groundtruth-dir", cli.groundtruth_dir,
                                 "write ground truth (poses.csv, labels/) of sources that have it to this folder");
  auto* o_depth = app.add_option("--depth-encoding", depth_encoding, "raw | zlib | rvl")
                      ->check(CLI::IsMember({"raw", "zlib", "rvl"}));
  auto* o_color =
      app.add_option("--color-encoding", color_encoding, "raw | jpeg | png")->check(CLI::IsMember({"raw", "jpeg", "png"}));
  auto* o_quality = app.add_option("--jpeg-quality", cli.encoding.jpeg_quality, "JPEG quality [1, 100]");
  app.add_option("--measure-encodings", measure,
                 "print bytes per frame of every encoding for the first N source frames and exit (no LCM)");
  CLI11_PARSE(app, argc, argv);

  setup_logging("capture", 0);
  install_signal_handlers();
  try {
    CaptureSettings settings = load_capture_settings(config_section(load_config_file(config_path), "capture"));
    const auto given = [](const CLI::Option* option) { return option->count() > 0; };
    if (given(o_source)) settings.source = cli.source;
    if (given(o_scenario)) settings.scenario = cli.scenario;
    if (given(o_seed)) settings.seed = cli.seed;
    if (given(o_sim_frames)) settings.sim_frames = cli.sim_frames;
    if (given(o_folder)) settings.tum_folder = cli.tum_folder;
    if (given(o_depth_scale)) settings.depth_scale = cli.depth_scale;
    if (given(o_oni)) settings.oni_file = cli.oni_file;
    if (given(o_uri)) settings.device_uri = cli.device_uri;
    if (given(o_rate)) settings.rate = parse_rate_mode(rate);
    if (given(o_speed)) settings.speed = cli.speed;
    if (given(o_timeout)) settings.lockstep_timeout_s = cli.lockstep_timeout_s;
    if (given(o_window)) settings.lockstep_window = cli.lockstep_window;
    if (given(o_max)) settings.max_frames = cli.max_frames;
    if (given(o_start)) settings.start_frame = cli.start_frame;
    if (given(o_loop)) settings.loop = cli.loop;
    if (given(o_truth)) settings.groundtruth_dir = cli.groundtruth_dir;
    if (given(o_depth)) settings.encoding.depth = parse_depth_encoding(depth_encoding);
    if (given(o_color)) settings.encoding.color = parse_color_encoding(color_encoding);
    if (given(o_quality)) settings.encoding.jpeg_quality = cli.encoding.jpeg_quality;
    settings.validate();

    auto source = make_source(settings, [] { return stop_requested(); });
    if (measure > 0) {
      if (settings.start_frame > 0) source->seek(settings.start_frame);
      return measure_encodings(*source, settings.encoding, measure);
    }
    lcm::LCM lcm(lcm_url(lcm_url_arg));
    if (!lcm.good()) {
      spdlog::error("cannot open LCM at {}", lcm_url(lcm_url_arg));
      return 1;
    }
    CaptureService service(lcm, std::move(settings), std::move(source));
    return service.run();
  } catch (const ConfigError& e) {
    spdlog::error("configuration refused: {}", e.what());
    return 2;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
