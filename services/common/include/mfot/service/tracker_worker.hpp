#pragma once
// A tracker worker's protocol, transport-free: it takes the messages a worker subscribes to
// (MFOT_MODEL_<worker_id>, MFOT_FRAME_DONE, MFOT_SCENE) as received bytes, validates them, and
// tracks the object the merger assigned to it (ObjectTracker). Steps:
//   1. on_model: a model addressed to this worker id *and* this process (worker_instance) is taken
//      (a new object starts a new filter; the grid is rebuilt only for a new version; an edit is
//      applied to the version held, and one of a version not held is not taken: a heartbeat at once
//      shows the merger this worker behind, and it sends the whole model again); a model
//      addressed to another says the merger finished its frame, and takes away the object it names
//      if this worker held it (moved to another worker, or retired);
//      on_frame_done: the merger finished a frame; the object held is dropped when the message
//      gives it to another worker or does not list it (retired); the entry addressed to this
//      worker, when it lists the model version held, stands for that model of this frame (pose of
//      a carried object, companion's motion, claimed points). A version not held leaves the scenes
//      waiting: this worker's heartbeats then show it behind, and the merger sends the model again;
//   2. on_scene: scenes queue in frame order (TrackerSceneQueue) until this worker holds its
//      object's model of the frame before;
//   3. step: tracks every released scene and publishes each estimate; heartbeats every
//      tracker.heartbeat_ms, and at once when a scene was skipped (the merger then stops waiting).
// What goes out is said to a TrackerSink (the LCM main publishes it; tests record it); the clock
// is passed in.

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "mfot/frame_done_t.hpp"
#include "mfot/heartbeat_t.hpp"
#include "mfot/object_model_t.hpp"
#include "mfot/service/lcm_util.hpp"
#include "mfot/service/object_tracker.hpp"
#include "mfot/service/pipeline_config.hpp"
#include "mfot/service/sender_lock.hpp"
#include "mfot/service/tracker_scene_queue.hpp"
#include "mfot/tracker_estimate_t.hpp"

namespace mfot::service {

class TrackerSink {
 public:
  TrackerSink() = default;
  TrackerSink(const TrackerSink&) = delete;
  TrackerSink& operator=(const TrackerSink&) = delete;
  virtual ~TrackerSink() = default;
  virtual void publish_estimate(const tracker_estimate_t& estimate) = 0;
  virtual void publish_heartbeat(const heartbeat_t& heartbeat) = 0;
  // The answer to a restarted merger's model request (MFOT_MODEL_REPORT): the object this worker
  // holds, its model, version and last pose.
  virtual void publish_model_report(const object_model_t& report) = 0;
  // Something a person watching the status should know.
  virtual void note(const std::string& message) = 0;
};

struct TrackerIdentity {
  std::int32_t worker_id = 0;
  std::int64_t instance = 0;  // this process (process_instance())
  std::string host;
};

class TrackerWorker {
 public:
  using Clock = std::chrono::steady_clock;

  TrackerWorker(const TrackerConfig& config, TrackerIdentity identity, TrackerSink& sink, MalformedCounter& malformed,
                std::function<Clock::time_point()> clock);
  TrackerWorker(const TrackerWorker&) = delete;
  TrackerWorker& operator=(const TrackerWorker&) = delete;

  void on_model(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name);
  // Model edits of a version this worker did not hold (not taken; it waited for the whole model).
  std::int64_t model_gaps() const { return model_gaps_; }
  void on_frame_done(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name);
  void on_scene(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name);
  // MFOT_STATUS: the merger's status keeps its process the one models are taken from (SenderLock).
  void on_status(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name);
  // A restarted merger asks for the object this worker holds (MFOT_MODEL_REQUEST, an object_model_t
  // naming worker_id, worker_instance and object_id, without points): when it names this worker,
  // this process and the object it holds, the worker answers with a report (publish_model_report):
  // object_id, version, frame_seq = the last frame it finished, its last pose and its model; any
  // other request is ignored, a malformed one counted.
  void on_model_request(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name);
  // Step 3; returns the frames tracked.
  int step();

  const ObjectTracker& tracker() const { return tracker_; }
  std::size_t queued_scenes() const { return scenes_.size(); }

 private:
  void track(const Scene& scene);
  void heartbeat(Clock::time_point now);
  void report_fallbacks();

  TrackerConfig config_;
  TrackerIdentity identity_;
  TrackerSink& sink_;
  MalformedCounter& malformed_;
  std::function<Clock::time_point()> clock_;
  ObjectTracker tracker_;
  TrackerSceneQueue scenes_;
  std::vector<Eigen::Vector3f> claimed_;  // of the last model or frame_done_t entry taken
  SenderLock merger_;                     // the merger process models are taken from
  Pose last_pose_;                        // the held object's last estimate (or its model's pose)
  Clock::time_point next_heartbeat_{};
  std::int64_t skipped_at_heartbeat_ = 0;
  std::int64_t reported_fallbacks_ = 0;
  std::int64_t reported_gaps_ = 0;
  std::int64_t model_gaps_ = 0;  // model edits of a version not held
  bool heartbeat_now_ = false;   // say at once that this worker is behind
};

}  // namespace mfot::service
