// mfot-preprocess: frame -> scene cloud (thesis chapter 4 preprocessing, see
// mfot/preprocessing.hpp). Subscribes frame_t on MFOT_FRAME, runs the Preprocessor (crop, table
// removal, 5 mm voxels, Euclidean clusters) and publishes scene_cloud_t on MFOT_SCENE. Frames
// that arrive while one is processed wait in order (in lockstep with a window of several frames,
// the next frames are preprocessed while the trackers and the merger work on earlier ones); beyond
// preprocess.queue_frames the oldest is dropped (counted). Malformed frames are counted and
// dropped. With preprocess.threads >= 2 depth and colour decode side by side, the next queued frame
// is decoded on a thread of its own while the current one is preprocessed (PreprocessQueue), and
// the Preprocessor splits its work over that many threads (the same scene for any count).

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <string>
#include <utility>

#include "mfot/frame_t.hpp"
#include "mfot/preprocessing.hpp"
#include "mfot/scene_cloud_t.hpp"
#include "mfot/service/config.hpp"
#include "mfot/service/convert.hpp"
#include "mfot/service/frame_codec.hpp"
#include "mfot/service/frame_gate.hpp"
#include "mfot/service/group_security.hpp"
#include "mfot/service/lcm_util.hpp"
#include "mfot/service/pipeline_config.hpp"
#include "mfot/service/preprocess_queue.hpp"
#include "mfot/service/service_main.hpp"
#include "mfot/service/status.hpp"

namespace mfot::service {
namespace {

using Clock = std::chrono::steady_clock;

class PreprocessService {
 public:
  PreprocessService(lcm::LCM& lcm, const PreprocessConfig& config)
      : lcm_(lcm),
        preprocessor_(config.preprocessor),
        queue_(static_cast<std::size_t>(config.queue_frames), config.preprocessor.threads),
        status_(lcm, "preprocess", 0, "cpu") {
    lcm_.subscribe(channel::kFrame, &PreprocessService::on_frame, this);
  }

  void run() {
    while (!stop_requested()) {
      if (!handle_for(lcm_, 5)) {
        if (stop_requested()) break;  // the signal interrupted the wait
        spdlog::error("LCM receive failed; stopping");
        break;
      }
      // Drain what is queued, then work on the oldest frame (one at a time, so frames that
      // arrive meanwhile join the queue in order).
      while (lcm_.handleTimeout(0) > 0) {
      }
      status_.set_queue_depth(static_cast<int>(queue_.size()));
      if (!queue_.empty()) {
        process(queue_.front());
        queue_.pop_front();
      }
      status_.tick();
    }
  }

 private:
  void on_frame(const lcm::ReceiveBuffer* rbuf, const std::string& chan) {
    if (!decode_message(rbuf, chan, queue_.incoming(), status_.malformed())) return;
    if (const auto refusal = gate_.admit(queue_.incoming())) {
      status_.malformed().record(chan, refusal->kind, refusal->detail);
      return;
    }
    if (queue_.push_incoming()) {
      ++dropped_;
      status_.set_message("dropped " + std::to_string(dropped_) + " frames (more than preprocess.queue_frames waited)");
    }
  }

  void process(const frame_t& message) {
    const auto start = Clock::now();
    Frame frame;
    try {
      frame = queue_.decode_front();  // of `message`
    } catch (const FrameCodecError& e) {
      status_.malformed().record(channel::kFrame, "undecodable frame", e.what());
      return;
    }
    try {
      preprocessor_.process(image_view(frame), message.seq);
    } catch (const std::invalid_argument& e) {
      status_.malformed().record(channel::kFrame, "invalid frame", e.what());
      return;
    }
    scene_to_message(preprocessor_.scene(), message, out_);
    out_.utime = now_utime();
    publish_message(lcm_, channel::kScene, out_);
    status_.frame_done(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
  }

  lcm::LCM& lcm_;
  Preprocessor preprocessor_;
  PreprocessQueue queue_;  // frames admitted and waiting, in arrival order
  StatusReporter status_;
  std::int64_t dropped_ = 0;
  FrameGate gate_;  // sizes and sequence of each frame before it is queued
  scene_cloud_t out_{};
};

}  // namespace
}  // namespace mfot::service

int main(int argc, char** argv) {
  using namespace mfot::service;
  CLI::App app{"mfot-preprocess: RGB-D frames -> table-free, voxelised, clustered scene clouds"};
  std::string config_path;  // empty: the built-in defaults (configs/default.yaml)
  std::string lcm_url_arg;
  app.add_option("--config", config_path, "YAML config (section `preprocess`)");
  app.add_option("--lcm-url", lcm_url_arg, "LCM provider URL (default: $MFOT_LCM_URL, $LCM_DEFAULT_URL or udpm ttl=0)");
  CLI11_PARSE(app, argc, argv);
  setup_logging("preprocess", 0);
  install_signal_handlers();
  return run_service_main([&] {
    const YAML::Node root = load_config_file(config_path);
    const PreprocessConfig config = load_preprocess_config(root);
    install_group_security(root);
    const mfot::PreprocessorOptions& options = config.preprocessor;
    lcm::LCM lcm(lcm_url(lcm_url_arg));
    if (!lcm.good()) {
      spdlog::error("cannot open LCM at {}", lcm_url(lcm_url_arg));
      return 1;
    }
    spdlog::info(
        "voxel {} m, crop z [{}, {}] m, table removal {}, clustering {} (tolerance {} m), {} threads, "
        "queue of {} frames",
        options.voxel_size, options.crop_min.z(), options.crop_max.z(), options.remove_plane ? "on" : "off",
        options.cluster ? "on" : "off", options.cluster_tolerance, options.threads, config.queue_frames);
    PreprocessService service(lcm, config);
    service.run();
    return 0;
  });
}
