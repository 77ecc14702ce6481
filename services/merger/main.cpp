// mfot-merger: the authority on objects. Wires LCM to mfot::ObjectManager (common/): waits for
// the assigned trackers' estimates of each scene (with a timeout), segments, updates models,
// creates and retires objects, assigns objects to tracker workers (and reassigns those of dead
// workers), and publishes models, segmentation and the controller-facing poses.

#include "mfot/heartbeat_t.hpp"
#include "mfot/metrics.hpp"
#include "mfot/object_manager.hpp"
#include "mfot/poses_t.hpp"
#include "mfot/segmentation_t.hpp"
#include "mfot/service/background_queue.hpp"
#include "mfot/service/config.hpp"
#include "mfot/service/pipeline_config.hpp"
#include "mfot/service/service_main.hpp"
#include "mfot/service/convert.hpp"
#include "mfot/service/frame_codec.hpp"
#include "mfot/service/lcm_util.hpp"
#include "mfot/service/run_writer.hpp"
#include "mfot/service/status.hpp"
#include "mfot/thread_pool.hpp"
#include "mfot/tracker_estimate_t.hpp"

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <thread>
#include <vector>

namespace mfot::service {
namespace {

using Clock = std::chrono::steady_clock;

// A model sent to a worker reaches it well within this on one host; a heartbeat that still
// disagrees with the assignment afterwards means the model (or the retirement) was lost.
constexpr std::chrono::milliseconds kModelInFlight{200};
// A heartbeat arriving this long after a scene, from a worker that has not finished that frame,
// means the worker never got the scene, or the model of the frame before, which it waits for
// (a worker heartbeats only between frames). Sending both again is harmless: a worker that has
// them already skips the repeats.
constexpr std::chrono::milliseconds kSceneInFlight{50};
// A scene is sent again at most this often and this many times: a worker that is merely slow
// skips the repeats; past them the estimate timeout decides.
constexpr std::chrono::milliseconds kSceneResendInterval{200};
constexpr int kMaxSceneResends = 3;
// A scene this many frames older than the last one finished starts a new frame sequence (a
// restarted capture or replay); anything closer is a late or repeated message.
constexpr std::int64_t kSequenceRestart = 100;
// Frames whose label image and fitting distances may wait for the output thread before the
// merger waits for it; it runs this much nicer than the merger's own thread.
constexpr std::size_t kOutputBacklog = 8;
constexpr int kOutputNiceIncrement = 5;

struct Worker {
  Clock::time_point last_seen;
  std::int32_t object_id = -1;         // as assigned by the merger
  Clock::time_point told_at;           // when it was last sent its assignment, a move or a retirement
  std::int64_t last_frame_seq = -1;    // from its last heartbeat
  bool alive = true;
};

class Merger {
 public:
  Merger(lcm::LCM& lcm, MergerConfig config, std::optional<std::string> output_dir, bool append_output)
      : lcm_(lcm), config_(std::move(config)), manager_(config_.manager), status_(lcm, "merger", 0, "cpu") {
    if (output_dir) {
      writer_ = std::make_unique<RunWriter>(*output_dir, append_output);
      outputs_ = std::make_unique<BackgroundQueue>("merger output writer", kOutputBacklog, kOutputNiceIncrement);
    }
    lcm_.subscribe(channel::kScene, &Merger::on_scene, this);
    lcm_.subscribe(channel::kEstimate, &Merger::on_estimate, this);
    lcm_.subscribe(channel::kHeartbeat, &Merger::on_heartbeat, this);
    if (writer_ && config_.write_labels) lcm_.subscribe(channel::kFrame, &Merger::on_frame, this);
  }

  void run() {
    while (!stop_requested()) {
      if (!handle_for(lcm_, 5)) {
        if (stop_requested()) break;  // the signal interrupted the wait
        spdlog::error("LCM receive failed; stopping");
        break;
      }
      const auto now = Clock::now();
      check_workers(now);
      assign_idle_workers(now);
      while (try_finish_frame(now)) {
      }
      status_.set_queue_depth(static_cast<int>(pending_.size()));
      status_.tick();
    }
    if (outputs_) outputs_->finish();
    if (writer_) writer_->flush();
    spdlog::info("stopped after {} frames; {} objects tracked", status_.frames(), manager_.objects().size());
  }

 private:
  struct PendingScene {
    Scene scene;
    std::vector<std::uint8_t> message;  // as received, to send again to a worker that lost it
    Clock::time_point arrived;
    Clock::time_point sent;  // arrival or the last time it was sent again
    int resends = 0;
  };

  void on_scene(const lcm::ReceiveBuffer* rbuf, const std::string& chan) {
    scene_cloud_t msg;
    if (!decode_message(rbuf, chan, msg, status_.malformed())) return;
    if (msg.frame_seq + kSequenceRestart < last_finished_seq_) {
      spdlog::warn("scene seq {} after {}: a new frame sequence", msg.frame_seq, last_finished_seq_);
      last_finished_seq_ = -1;
      estimates_.clear();
    }
    // Our own re-sent scenes come back here; a reordered one joins the queue in sequence order.
    const auto at = std::find_if(pending_.begin(), pending_.end(),
                                 [&](const PendingScene& p) { return p.scene.frame_seq >= msg.frame_seq; });
    if (at != pending_.end() && at->scene.frame_seq == msg.frame_seq) return;
    if (msg.frame_seq <= last_finished_seq_) {
      status_.set_message("late or repeated scene " + std::to_string(msg.frame_seq));
      return;
    }
    PendingScene pending;
    if (auto error = scene_from_message(msg, pending.scene)) {
      status_.malformed().record(chan, "invalid scene", *error);
      return;
    }
    const auto* bytes = static_cast<const std::uint8_t*>(rbuf->data);
    pending.message.assign(bytes, bytes + rbuf->data_size);
    pending.arrived = pending.sent = Clock::now();
    voxel_size_ = msg.voxel_size;
    pending_.insert(at, std::move(pending));
  }

  void on_estimate(const lcm::ReceiveBuffer* rbuf, const std::string& chan) {
    tracker_estimate_t msg;
    if (!decode_message(rbuf, chan, msg, status_.malformed())) return;
    ObjectEstimate estimate;
    if (auto error = pose_from_arrays(msg.position, msg.orientation, estimate.pose)) {
      status_.malformed().record(chan, "invalid estimate", *error);
      return;
    }
    if (!std::isfinite(msg.confidence)) {
      status_.malformed().record(chan, "invalid estimate", "non-finite confidence");
      return;
    }
    estimate.confidence = msg.confidence;
    // Only the owner's estimates count: a worker that has not yet heard that its object moved
    // (or a merger restart) must not overwrite the owner's.
    const auto owner = owner_.find(msg.object_id);
    if (owner == owner_.end() || owner->second != msg.worker_id) return;
    note_progress(msg.object_id, msg.frame_seq);
    if (msg.frame_seq <= last_finished_seq_) return;  // too late: that frame was published stale
    estimates_[msg.frame_seq][msg.object_id] = estimate;
  }

  // The owner of `object_id` has finished frame `seq`: it will not send an estimate for it or
  // any earlier frame (a lost estimate or a skipped scene), so those frames need not wait.
  void note_progress(std::int32_t object_id, std::int64_t seq) {
    auto [it, inserted] = progress_.try_emplace(object_id, seq);
    if (!inserted) it->second = std::max(it->second, seq);
  }

  void on_heartbeat(const lcm::ReceiveBuffer* rbuf, const std::string& chan) {
    heartbeat_t msg;
    if (!decode_message(rbuf, chan, msg, status_.malformed())) return;
    const auto now = Clock::now();
    auto [it, inserted] = workers_.try_emplace(msg.worker_id);
    Worker& w = it->second;
    if (inserted || !w.alive) {
      spdlog::info("tracker worker {} is {}", msg.worker_id, inserted ? "up" : "back");
      w.object_id = -1;
    }
    w.alive = true;
    w.last_seen = now;
    w.last_frame_seq = msg.last_frame_seq;
    if (w.object_id >= 0 && msg.object_id == w.object_id) note_progress(w.object_id, msg.last_frame_seq);
    if (msg.object_id == w.object_id || now - w.told_at <= kModelInFlight) return;
    w.told_at = now;
    // The worker lost its model (or restarted): send it again.
    if (w.object_id >= 0) {
      spdlog::warn("worker {} does not hold object {}; sending its model again", msg.worker_id, w.object_id);
      publish_model(w.object_id, msg.worker_id);
    }
    // The worker holds an object that is not its own (it missed the move or the retirement, or
    // this merger restarted): tell it who owns that object now, or that it is gone.
    if (msg.object_id >= 0) {
      const auto owner = owner_.find(msg.object_id);
      if (manager_.objects().count(msg.object_id)) {
        spdlog::warn("worker {} still holds object {}; telling it the owner is worker {}", msg.worker_id,
                     msg.object_id, owner == owner_.end() ? -1 : owner->second);
        publish_model(msg.object_id, owner == owner_.end() ? -1 : owner->second);
      } else {
        spdlog::warn("worker {} holds object {}, which does not exist; retiring it", msg.worker_id, msg.object_id);
        publish_retirement(msg.object_id, last_finished_seq_);
        // After a restart of this merger: controllers knew that id as another object.
        manager_.reserve_ids_through(msg.object_id);
      }
    }
  }

  void on_frame(const lcm::ReceiveBuffer* rbuf, const std::string& chan) {
    frame_t msg;
    if (!decode_message(rbuf, chan, msg, status_.malformed())) return;
    // Decoded on the output thread: the frame arrives while preprocess works on it, and this
    // thread's decoding would take the CPU from the frame-to-pose path.
    const std::int64_t seq = msg.seq;
    frames_[seq] = std::move(msg);
    while (frames_.size() > 64) frames_.erase(frames_.begin());
  }

  void check_workers(Clock::time_point now) {
    for (auto& [id, w] : workers_) {
      if (!w.alive || now - w.last_seen <= std::chrono::milliseconds(config_.worker_timeout_ms)) continue;
      w.alive = false;
      spdlog::warn("tracker worker {} silent for {} ms: declared dead{}", id, config_.worker_timeout_ms,
                   w.object_id >= 0 ? fmt::format("; object {} will be reassigned", w.object_id) : "");
      if (w.object_id >= 0) {
        owner_.erase(w.object_id);
        progress_.erase(w.object_id);
      }
      w.object_id = -1;
    }
  }

  // Every object without a live worker goes to the idle worker with the lowest id.
  void assign_idle_workers(Clock::time_point now) {
    for (const auto& [object_id, object] : manager_.objects()) {
      if (owner_.count(object_id)) continue;
      for (auto& [worker_id, w] : workers_) {
        if (!w.alive || w.object_id >= 0) continue;
        w.object_id = object_id;
        w.told_at = now;
        owner_[object_id] = worker_id;
        progress_.erase(object_id);
        spdlog::info("object {} assigned to worker {}", object_id, worker_id);
        publish_model(object_id, worker_id);
        break;
      }
    }
  }

  bool try_finish_frame(Clock::time_point now) {
    if (pending_.empty()) return false;
    PendingScene& next = pending_.front();
    if (!started_) {
      const auto alive = std::count_if(workers_.begin(), workers_.end(), [](const auto& w) { return w.second.alive; });
      if (alive < config_.expected_workers &&
          now - next.arrived < std::chrono::milliseconds(config_.startup_timeout_ms)) {
        return false;
      }
      started_ = true;
    }
    const std::int64_t seq = next.scene.frame_seq;
    const auto& got = estimates_[seq];
    bool complete = true;
    lagging_.clear();
    // Trackers could work on this frame only once the frame before was finished.
    const auto sent = std::max(next.sent, last_finish_);
    for (const auto& [object_id, worker_id] : owner_) {
      if (got.count(object_id)) continue;
      const auto progress = progress_.find(object_id);
      if (progress != progress_.end() && progress->second >= seq) continue;  // lost, or skipped
      complete = false;
      const Worker& w = workers_.at(worker_id);
      if (w.last_frame_seq < seq && w.last_seen > sent + kSceneInFlight && now - sent > kSceneResendInterval) {
        lagging_.emplace_back(object_id, worker_id);
      }
    }
    if (!complete && !lagging_.empty() && next.resends < kMaxSceneResends) {
      spdlog::info("a worker did not get the scene of frame {} or the model before it; sending them again", seq);
      for (const auto& [object_id, worker_id] : lagging_) publish_model(object_id, worker_id);
      lcm_.publish(channel::kScene, next.message.data(), static_cast<unsigned>(next.message.size()));
      next.sent = now;
      ++next.resends;
    }
    const auto waiting_since = std::max(next.arrived, last_finish_);  // not sent: resends do not extend it
    const bool timed_out = now - waiting_since > std::chrono::milliseconds(config_.estimate_timeout_ms);
    if (!complete && !timed_out) return false;
    finish_frame(next, now);
    pending_.pop_front();
    last_finish_ = Clock::now();
    return true;
  }

  void finish_frame(PendingScene& pending, Clock::time_point now) {
    const auto t0 = Clock::now();
    const Scene& scene = pending.scene;
    std::map<std::int32_t, ObjectEstimate> estimates;
    for (const auto& [object_id, estimate] : estimates_[scene.frame_seq]) {
      if (owner_.count(object_id)) estimates.emplace(object_id, estimate);
    }
    const ObjectManagerFrame& result = manager_.process(scene.cloud, scene.cluster, estimates);
    last_finished_seq_ = scene.frame_seq;
    estimates_.erase(estimates_.begin(), estimates_.upper_bound(scene.frame_seq));

    for (const std::int32_t id : result.retired) {
      spdlog::info("object {} retired (no support)", id);
      const auto it = owner_.find(id);
      const std::int32_t worker = it == owner_.end() ? -1 : it->second;
      if (it != owner_.end()) {
        workers_[worker].object_id = -1;
        workers_[worker].told_at = now;
        owner_.erase(it);
      }
      progress_.erase(id);
      publish_retirement(id, scene.frame_seq);
    }
    for (const std::int32_t id : result.created) spdlog::info("object {} created at frame {}", id, scene.frame_seq);
    assign_idle_workers(now);
    for (const auto& [object_id, worker_id] : owner_) {
      if (std::find(result.created.begin(), result.created.end(), object_id) == result.created.end()) {
        publish_model(object_id, worker_id);
      }
    }

    segmentation_t seg;
    seg.utime = now_utime();
    seg.frame_seq = scene.frame_seq;
    seg.num_points = static_cast<std::int32_t>(result.labels.size());
    seg.label = result.labels;
    lcm_.publish(channel::kSegmentation, &seg);

    poses_t poses;
    poses.utime = now_utime();
    poses.frame_seq = scene.frame_seq;
    poses.capture_utime = scene.capture_utime;
    for (const auto& [id, object] : manager_.objects()) {
      object_pose_t p{};
      p.id = id;
      pose_to_arrays(object.pose, p.position, p.orientation);
      pose_to_arrays(Pose::from_isometry(config_.world_from_camera.isometry() * object.pose.isometry()),
                     p.world_position, p.world_orientation);
      for (int i = 0; i < 3; ++i) {
        p.linear_velocity[i] = object.velocity[i] * config_.fps;
        p.angular_velocity[i] = object.velocity[3 + i] * config_.fps;
      }
      p.confidence = object.confidence;
      p.stale = object.stale;
      poses.objects.push_back(p);
    }
    poses.num_objects = static_cast<std::int32_t>(poses.objects.size());
    write_poses(scene);
    lcm_.publish(channel::kPoses, &poses);
    // The files that only evaluation reads come after the poses, off the frame-to-pose path (in
    // lockstep the next frame is on its way meanwhile).
    write_frame_outputs(scene, result);
    status_.frame_done(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
  }

  // poses.csv, flushed before the poses are published: every published frame's poses are on
  // disk even if this process is killed right after (a restarted merger continues the file).
  void write_poses(const Scene& scene) {
    if (!writer_) return;
    for (const auto& [id, object] : manager_.objects()) {
      writer_->write_pose(scene.frame_seq, scene.capture_utime, id, object.pose, object.confidence, object.stale);
    }
    writer_->flush_poses();
  }

  // fitting.csv and the label image of a published frame, computed and written on the output
  // thread from copies of what they need (a merger killed meanwhile leaves the last frames
  // without them; label images appear whole or not at all).
  void write_frame_outputs(const Scene& scene, const ObjectManagerFrame& result) {
    if (!writer_) return;
    struct FittingInput {
      std::int32_t id;
      std::vector<Eigen::Vector3f> model;
      Pose pose;
    };
    std::vector<FittingInput> fitting;
    if (config_.fitting_distance && !scene.cloud.empty()) {
      for (const auto& [id, object] : manager_.objects()) fitting.push_back({id, object.model.cloud.positions, object.pose});
    }
    std::optional<frame_t> frame;
    if (config_.write_labels) {
      const auto it = frames_.find(scene.frame_seq);
      if (it == frames_.end()) {
        status_.set_message("no frame for labels of seq " + std::to_string(scene.frame_seq));
      } else {
        frame = std::move(it->second);
        frames_.erase(frames_.begin(), std::next(it));
      }
    }
    outputs_->push([this, seq = scene.frame_seq, points = scene.cloud.positions, labels = result.labels,
                    fitting = std::move(fitting), frame = std::move(frame), voxel_size = voxel_size_] {
      // The fitting distances and the label image are independent: side by side they keep the
      // output thread ahead of the frame rate (at ~100 frames/s one after the other did not).
      // Made here so that its thread inherits the output thread's lower priority. Below 4 cores
      // there is no core to spare for it (the 2-core dev machine's group is CPU-bound): one thread.
      if (!output_split_) output_split_ = std::make_unique<ThreadPool>(std::thread::hardware_concurrency() >= 4 ? 2 : 1);
      output_split_->run(2, [&](std::size_t part) {
        if (part == 0) {
          if (fitting.empty()) return;
          fitting_.set_scene(points);
          for (const auto& object : fitting) {
            writer_->write_fitting(seq, object.id, fitting_.evaluate(object.model, object.pose).mean);
          }
          return;
        }
        if (!frame) return;
        try {
          const Frame f = decode_frame(*frame, FrameParts::kDepthOnly);  // label images need depth only
          writer_->write_labels(seq, dense_labels(f.width, f.height, f.fx, f.fy, f.cx, f.cy, f.depth_mm, voxel_size,
                                                  points, labels));
        } catch (const FrameCodecError& e) {
          status_.malformed().record(channel::kFrame, "undecodable frame", e.what());  // MalformedCounter locks
        }
      });
      writer_->flush_fitting();
    });
  }

  void publish_retirement(std::int32_t object_id, std::int64_t frame_seq) {
    object_model_t retire{};
    retire.utime = now_utime();
    retire.frame_seq = frame_seq;
    retire.object_id = object_id;
    retire.worker_id = -1;
    retire.version = -1;
    retire.orientation[0] = 1;
    lcm_.publish(channel::kModel, &retire);
  }

  void publish_model(std::int32_t object_id, std::int32_t worker_id) {
    const ManagedObject& object = manager_.objects().at(object_id);
    object_model_t msg{};
    msg.utime = now_utime();
    msg.frame_seq = last_finished_seq_;
    msg.object_id = object_id;
    msg.worker_id = worker_id;
    msg.version = object.version;
    pose_to_arrays(object.pose, msg.position, msg.orientation);
    for (int i = 0; i < 6; ++i) msg.velocity[i] = object.velocity[i];
    model_to_message(object.model, msg);
    lcm_.publish(channel::kModel, &msg);
  }

  lcm::LCM& lcm_;
  MergerConfig config_;
  ObjectManager manager_;
  StatusReporter status_;
  FittingDistanceEvaluator fitting_;  // used on the output thread only
  std::unique_ptr<ThreadPool> output_split_;  // output thread only: fitting beside the label image
  std::unique_ptr<RunWriter> writer_;
  // Declared after what its jobs use, so it is destroyed (finishing them) first.
  std::unique_ptr<BackgroundQueue> outputs_;
  std::deque<PendingScene> pending_;
  // When the last frame was finished: the next frame's estimates can come only after it (the
  // trackers wait for its models), so its estimate timeout runs from then or its arrival.
  Clock::time_point last_finish_{};
  std::vector<std::pair<std::int32_t, std::int32_t>> lagging_;  // (object, worker) that may lack the scene or model
  std::map<std::int64_t, std::map<std::int32_t, ObjectEstimate>> estimates_;  // frame -> object -> estimate
  std::map<std::int32_t, Worker> workers_;
  std::map<std::int32_t, std::int32_t> owner_;  // object -> worker
  std::map<std::int32_t, std::int64_t> progress_;  // object -> last frame its owner finished
  std::map<std::int64_t, frame_t> frames_;       // for dense label images, as received
  std::int64_t last_finished_seq_ = -1;
  float voxel_size_ = 0.005f;
  bool started_ = false;
};

}  // namespace
}  // namespace mfot::service

int main(int argc, char** argv) {
  using namespace mfot::service;
  CLI::App app{"mfot-merger: segmentation, model update and object management"};
  std::string config_path = "configs/default.yaml";
  std::string lcm_url_arg;
  std::string output_dir;
  bool append_output = false;
  app.add_option("--config", config_path, "YAML config (section `merger`)");
  app.add_option("--lcm-url", lcm_url_arg, "LCM provider URL (default: $LCM_DEFAULT_URL or udpm ttl=0)");
  app.add_option("--output-dir", output_dir, "write poses.csv, fitting.csv and labels/ here");
  app.add_flag("--append-output", append_output,
               "continue the CSV files already in --output-dir (a restarted merger) instead of starting them anew");
  CLI11_PARSE(app, argc, argv);
  setup_logging("merger", 0);
  install_signal_handlers();
  return run_service_main([&] {
    const MergerConfig config = load_merger_config(load_config_file(config_path));
    lcm::LCM lcm(lcm_url(lcm_url_arg));
    if (!lcm.good()) {
      spdlog::error("cannot open LCM at {}", lcm_url(lcm_url_arg));
      return 1;
    }
    Merger merger(lcm, config, output_dir.empty() ? std::nullopt : std::optional<std::string>(output_dir),
                  append_output);
    spdlog::info("merger up (tau {} m, alpha {}), LCM {}", config.manager.segmentation.tau,
                 config.manager.model_update.alpha, lcm_url(lcm_url_arg));
    merger.run();
    return 0;
  });
}
