// mfot-tracker: one tracker worker. It idles until the merger assigns it an object on
// MFOT_MODEL, then runs that object's particle filter (thesis 2.2.2, 3.3) on every scene and
// publishes the estimate. It heartbeats so the merger can hand its object to another worker if
// this one dies or stalls. The likelihood backend (JCSD on CUDA or CPU, or the point-to-point
// baseline) is chosen at run time; each worker owns its CUDA stream.

#include "mfot/cuda/likelihood_factory.hpp"
#include "mfot/heartbeat_t.hpp"
#include "mfot/particle_filter.hpp"
#include "mfot/service/config.hpp"
#include "mfot/service/pipeline_config.hpp"
#include "mfot/service/service_main.hpp"
#include "mfot/service/convert.hpp"
#include "mfot/service/lcm_util.hpp"
#include "mfot/service/status.hpp"
#include "mfot/tracker_estimate_t.hpp"
#include "mfot/tracking_step.hpp"

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <chrono>
#include <memory>
#include <optional>

namespace mfot::service {
namespace {

using Clock = std::chrono::steady_clock;

// A scene this many frames older than the last one tracked starts a new sequence (a restarted
// capture or replay); anything closer is a late or repeated message and is skipped.
constexpr std::int64_t kSequenceRestart = 100;

class TrackerWorker {
 public:
  TrackerWorker(lcm::LCM& lcm, TrackerConfig config, int worker_id)
      : lcm_(lcm),
        config_(std::move(config)),
        worker_id_(worker_id),
        choice_(make_likelihood(config_.likelihood)),
        status_(lcm, "tracker", worker_id, choice_.backend) {
    spdlog::info("likelihood backend {}{}", choice_.backend, choice_.note.empty() ? "" : " (" + choice_.note + ")");
    lcm_.subscribe(channel::kModel, &TrackerWorker::on_model, this);
    lcm_.subscribe(channel::kScene, &TrackerWorker::on_scene, this);
  }

  void run() {
    auto next_heartbeat = Clock::now();
    while (!stop_requested()) {
      if (!handle_for(lcm_, 5)) {
        if (stop_requested()) break;  // the signal interrupted the wait
        spdlog::error("LCM receive failed; stopping");
        break;
      }
      // Drain what is queued, then work on the newest scene only.
      int queued = 0;
      while (lcm_.handleTimeout(0) > 0) ++queued;
      status_.set_queue_depth(queued);
      // An idle worker keeps the newest scene: if the merger assigns it an object while that
      // frame is still open, it tracks the frame at once instead of the merger waiting for it.
      if (latest_scene_ && filter_) {
        track(*latest_scene_);
        latest_scene_.reset();
      }
      const auto now = Clock::now();
      if (now >= next_heartbeat) {
        heartbeat();
        next_heartbeat = now + std::chrono::milliseconds(config_.heartbeat_ms);
      }
      status_.tick();
    }
  }

 private:
  void on_model(const lcm::ReceiveBuffer* rbuf, const std::string& chan) {
    object_model_t msg;
    if (!decode_message(rbuf, chan, msg, status_.malformed())) return;
    if (msg.worker_id != worker_id_) {
      if (object_id_ == msg.object_id) {
        spdlog::info("object {} {}", object_id_, msg.worker_id < 0 ? "retired" : "moved to another worker");
        object_id_ = -1;
        filter_.reset();
        latest_scene_.reset();
      }
      return;
    }
    ObjectModel model;
    Pose pose;
    PoseVector velocity;  // the filter learns its own velocity within two frames
    if (auto error = model_from_message(msg, model, pose, velocity)) {
      status_.malformed().record(chan, "invalid model", *error);
      return;
    }
    if (model.cloud.empty()) {
      status_.malformed().record(chan, "invalid model", "empty model assigned");
      return;
    }
    // A model the likelihood cannot take (e.g. a JCSD grid beyond its corner limit at a tiny
    // cell_size) is refused like any invalid model instead of stopping the worker.
    try {
      choice_.likelihood->set_model(model);
    } catch (const std::exception& e) {
      status_.malformed().record(chan, "invalid model", e.what());
      return;
    }
    if (object_id_ != msg.object_id || !filter_) {
      object_id_ = msg.object_id;
      ParticleFilterOptions options = config_.filter;
      options.seed = config_.filter.seed + static_cast<std::uint64_t>(msg.object_id);
      filter_ = std::make_unique<ParticleFilter>(options);
      filter_->reset(pose);
      step_.reset();
      spdlog::info("took object {} (model v{} of frame {}, {} points)", object_id_, msg.version, msg.frame_seq,
                   model.cloud.size());
      // A scene the merger had already finished when it sent this model is not ours to track.
      if (latest_scene_ && latest_scene_->frame_seq <= msg.frame_seq) latest_scene_.reset();
    }
    model_version_ = msg.version;
    model_box_ = model_bounding_box(model);
    model_ = std::move(model);
  }

  void on_scene(const lcm::ReceiveBuffer* rbuf, const std::string& chan) {
    scene_cloud_t msg;
    if (!decode_message(rbuf, chan, msg, status_.malformed())) return;
    if (msg.frame_seq + kSequenceRestart < last_frame_) {
      spdlog::info("scene seq {} after {}: a new frame sequence", msg.frame_seq, last_frame_);
      last_frame_ = -1;
      latest_scene_.reset();
    }
    // Frames are tracked in sequence order only: a late (reordered) scene, or one the merger
    // sends again after this worker already tracked it, is skipped.
    if (msg.frame_seq <= last_frame_ || (latest_scene_ && msg.frame_seq <= latest_scene_->frame_seq)) return;
    Scene scene;
    if (auto error = scene_from_message(msg, scene)) {
      status_.malformed().record(chan, "invalid scene", *error);
      return;
    }
    if (latest_scene_ && filter_) status_.set_message("dropped scene " + std::to_string(latest_scene_->frame_seq));
    latest_scene_ = std::move(scene);
  }

  void track(Scene& scene) {
    if (object_id_ < 0 || !filter_) return;
    const auto t0 = Clock::now();
    scene.features = compute_smr(scene.cloud.colors);
    const TrackingStepResult result =
        step_.track(scene.cloud, scene.features, model_, model_box_, *filter_, *choice_.likelihood);
    spdlog::debug("frame {} object {}: {} share {:.2f}, {} points scored, {} occluders left out", scene.frame_seq,
                  object_id_, result.held ? "held" : "stepped", result.occluded_share, result.hypothesis_points,
                  result.occluders_removed);
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();

    tracker_estimate_t msg{};
    msg.utime = now_utime();
    msg.frame_seq = scene.frame_seq;
    msg.object_id = object_id_;
    msg.worker_id = worker_id_;
    msg.model_version = model_version_;
    pose_to_arrays(result.estimate, msg.position, msg.orientation);
    msg.confidence = filter_->confidence();
    msg.effective_sample_size = filter_->effective_sample_size();
    msg.num_particles = config_.filter.num_particles;
    msg.num_hypothesis_points = static_cast<std::int32_t>(result.hypothesis_points);
    msg.compute_ms = static_cast<float>(ms);
    lcm_.publish(channel::kEstimate, &msg);
    last_frame_ = scene.frame_seq;
    status_.frame_done(ms);
  }

  void heartbeat() {
    heartbeat_t hb{};
    hb.utime = now_utime();
    hb.worker_id = worker_id_;
    hb.object_id = object_id_;
    hb.last_frame_seq = last_frame_;
    lcm_.publish(channel::kHeartbeat, &hb);
  }

  lcm::LCM& lcm_;
  TrackerConfig config_;
  int worker_id_;
  LikelihoodChoice choice_;
  StatusReporter status_;
  std::int32_t object_id_ = -1;
  std::int32_t model_version_ = 0;
  std::int64_t last_frame_ = -1;
  ObjectModel model_;
  Eigen::AlignedBox3f model_box_;
  std::unique_ptr<ParticleFilter> filter_;
  std::optional<Scene> latest_scene_;
  TrackingStep step_{config_.step};
};

}  // namespace
}  // namespace mfot::service

int main(int argc, char** argv) {
  using namespace mfot::service;
  CLI::App app{"mfot-tracker: one particle-filter tracker worker"};
  std::string config_path = "configs/default.yaml";
  std::string lcm_url_arg;
  int worker_id = 0;
  app.add_option("--config", config_path, "YAML config (section `tracker`)");
  app.add_option("--lcm-url", lcm_url_arg, "LCM provider URL (default: $LCM_DEFAULT_URL or udpm ttl=0)");
  app.add_option("--worker-id", worker_id, "this worker's id, unique in the group")->required()->check(CLI::Range(0, 100000));
  CLI11_PARSE(app, argc, argv);
  setup_logging("tracker", worker_id);
  install_signal_handlers();
  return run_service_main([&] {
    const TrackerConfig config = load_tracker_config(load_config_file(config_path));
    lcm::LCM lcm(lcm_url(lcm_url_arg));
    if (!lcm.good()) {
      spdlog::error("cannot open LCM at {}", lcm_url(lcm_url_arg));
      return 1;
    }
    TrackerWorker worker(lcm, config, worker_id);
    worker.run();
    return 0;
  });
}
