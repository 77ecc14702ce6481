// mfot-tracker: one tracker worker. It idles until the merger assigns it an object on
// MFOT_MODEL, then runs that object's particle filter (thesis 2.2.2, 3.3) on every scene and
// publishes the estimate. It heartbeats so the merger can hand its object to another worker if
// this one dies or stalls. The likelihood backend (JCSD on CUDA or CPU, or the point-to-point
// baseline) is chosen at run time; each worker owns its CUDA stream. Scenes wait in a
// TrackerSceneQueue until the worker holds its object's model of the previous frame, so with a
// lockstep window of several frames the results are those of a window of one.

#include "mfot/cuda/likelihood_factory.hpp"
#include "mfot/heartbeat_t.hpp"
#include "mfot/particle_filter.hpp"
#include "mfot/service/config.hpp"
#include "mfot/service/pipeline_config.hpp"
#include "mfot/service/service_main.hpp"
#include "mfot/service/convert.hpp"
#include "mfot/service/lcm_util.hpp"
#include "mfot/service/status.hpp"
#include "mfot/service/tracker_scene_queue.hpp"
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

class TrackerWorker {
 public:
  TrackerWorker(lcm::LCM& lcm, TrackerConfig config, int worker_id)
      : lcm_(lcm),
        config_(std::move(config)),
        worker_id_(worker_id),
        choice_(make_likelihood(config_.likelihood)),
        status_(lcm, "tracker", worker_id, choice_.backend),
        scenes_(config_.scenes) {
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
      // Drain what is queued, then track every scene whose model is here, in order. An idle
      // worker keeps its scenes too: if the merger assigns it an object while those frames are
      // still open, it tracks them at once instead of the merger waiting for it.
      while (lcm_.handleTimeout(0) > 0) {
      }
      while (auto scene = scenes_.next(Clock::now())) track(*scene);
      status_.set_queue_depth(static_cast<int>(scenes_.size()));
      report_fallbacks();
      const auto now = Clock::now();
      // A skipped scene is said at once, so the merger does not wait for its estimate.
      if (now >= next_heartbeat || scenes_.skipped() != skipped_at_heartbeat_) {
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
    if (msg.frame_seq < -1) {
      status_.malformed().record(chan, "invalid model", "frame_seq below -1");
      return;
    }
    // Addressed to this worker id in another process (two processes given one id): not ours.
    if (msg.worker_id != worker_id_ || msg.worker_instance != process_instance()) {
      scenes_.frame_finished(msg.frame_seq);
      if (object_id_ == msg.object_id) {
        spdlog::info("object {} {}", object_id_, msg.worker_id < 0 ? "retired" : "moved to another worker");
        object_id_ = -1;
        filter_.reset();
        scenes_.object_dropped();
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
    // A model older than (or the same as) the one held arrived late or again: keep ours.
    if (!scenes_.accepts_model(msg.object_id, msg.frame_seq)) return;
    // A model the likelihood cannot take (e.g. a JCSD grid beyond its corner limit at a tiny
    // cell_size) is refused like any invalid model instead of stopping the worker.
    try {
      choice_.likelihood->set_model(model);
    } catch (const std::exception& e) {
      status_.malformed().record(chan, "invalid model", e.what());
      return;
    }
    if (object_id_ != msg.object_id) {
      object_id_ = msg.object_id;
      ParticleFilterOptions options = config_.filter;
      options.seed = config_.filter.seed + static_cast<std::uint64_t>(msg.object_id);
      filter_ = std::make_unique<ParticleFilter>(options);
      filter_->reset(pose);
      step_.reset();
      spdlog::info("took object {} (model v{} of frame {}, {} points)", object_id_, msg.version, msg.frame_seq,
                   model.cloud.size());
    }
    // Scenes the merger had already finished when it sent this model are not ours to track.
    scenes_.model_received(msg.object_id, msg.frame_seq);
    model_version_ = msg.version;
    model_box_ = model_bounding_box(model);
    model_ = std::move(model);
  }

  void on_scene(const lcm::ReceiveBuffer* rbuf, const std::string& chan) {
    scene_cloud_t msg;
    if (!decode_message(rbuf, chan, msg, status_.malformed())) return;
    Scene scene;
    if (auto error = scene_from_message(msg, scene)) {
      status_.malformed().record(chan, "invalid scene", *error);
      return;
    }
    // Frames are tracked in sequence order only: a late (reordered) scene, or one the merger
    // sends again after this worker already has it, is refused.
    const std::int64_t skipped = scenes_.skipped();
    if (scenes_.add_scene(std::move(scene)) == TrackerSceneQueue::Arrival::kNewSequence) {
      spdlog::info("scene seq {}: a new frame sequence", msg.frame_seq);
    }
    if (scenes_.skipped() != skipped) {
      status_.set_message("skipped " + std::to_string(scenes_.skipped()) + " scenes (more than tracker.queue_scenes)");
    }
  }

  void report_fallbacks() {
    if (scenes_.gaps_passed() != reported_gaps_) {
      reported_gaps_ = scenes_.gaps_passed();
      spdlog::warn("tracked a scene ahead of a missing one ({} times so far)", reported_gaps_);
      status_.set_message("tracked " + std::to_string(reported_gaps_) + " scenes ahead of a missing one");
    }
    if (scenes_.fallbacks() == reported_fallbacks_) return;
    reported_fallbacks_ = scenes_.fallbacks();
    spdlog::warn("tracked a scene without the previous frame's model after {} ms ({} times so far)",
                 config_.scenes.model_wait.count(), reported_fallbacks_);
    status_.set_message("tracked " + std::to_string(reported_fallbacks_) +
                        " scenes without the previous frame's model (tracker.model_wait_ms)");
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
    status_.frame_done(ms);
  }

  void heartbeat() {
    heartbeat_t hb{};
    hb.utime = now_utime();
    hb.worker_id = worker_id_;
    hb.instance = process_instance();
    hb.host = host_name();
    hb.object_id = object_id_;
    hb.last_frame_seq = scenes_.last_done();
    skipped_at_heartbeat_ = scenes_.skipped();
    lcm_.publish(channel::kHeartbeat, &hb);
  }

  lcm::LCM& lcm_;
  TrackerConfig config_;
  int worker_id_;
  LikelihoodChoice choice_;
  StatusReporter status_;
  std::int32_t object_id_ = -1;
  std::int32_t model_version_ = 0;
  ObjectModel model_;
  Eigen::AlignedBox3f model_box_;
  std::unique_ptr<ParticleFilter> filter_;
  TrackerSceneQueue scenes_;
  std::int64_t reported_fallbacks_ = 0;
  std::int64_t reported_gaps_ = 0;
  std::int64_t skipped_at_heartbeat_ = 0;
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
