#pragma once
// The merger's protocol engine, transport-free: it takes the messages the merger subscribes to
// (scenes, estimates, heartbeats) as received bytes, validates them, and runs the frame loop of
// thesis 3.1 / 3.4 around ObjectManager. Steps, per call of step() (at the clock's time):
//   1. workers silent past the timeout are declared dead (WorkerPool::expire);
//   2. objects without a live owner go to idle workers, who are sent their model (assign);
//   3. while the oldest open frame is due (FrameAssembler::poll; lost scenes and models are sent
//      again first): ObjectManager::process with the owners' estimates, then retirements are
//      sent to their owners, idle workers take the new objects, an owner whose object's model
//      changed (a new version) gets the model (as an edit of the version it was sent last, where
//      the sink finds that smaller: model_delta.hpp), the frame's end goes to every worker
//      (frame_done_t: every object's owner and model version, and what its tracker needs beside
//      the model), then the frame's segmentation and poses (MergerSink::publish_frame).
// A model goes only to the worker it names (MergerSink::send_model's recipient); a tracker that
// lacks the version frame_done_t lists (an edit of a version it does not hold is not taken) waits, falls
// behind, and its heartbeats make the frame assembler send the whole model again (FrameAssembler::poll).
// What goes out is said to a MergerSink (the LCM main publishes it; tests record it). The clock is
// passed in, so tests drive time.

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <span>
#include <string>
#include <vector>

#include "mfot/frame_done_t.hpp"
#include "mfot/object_manager.hpp"
#include "mfot/service/convert.hpp"
#include "mfot/service/frame_assembler.hpp"
#include "mfot/service/lcm_util.hpp"
#include "mfot/service/model_delta.hpp"
#include "mfot/service/object_resumer.hpp"
#include "mfot/service/worker_pool.hpp"

namespace mfot::service {

struct MergerCoreOptions {
  ObjectManagerOptions manager;
  WorkerPoolOptions workers;
  FrameAssemblerOptions frames;
  // A restarted merger resumes the objects its workers still hold (ObjectResumer; listen 0 = off).
  ObjectResumerOptions resume;
  // Each model goes out with the other objects' model points inside the object's box grown by
  // this (metres, [0, 1]; the trackers' hypothesis margin plus their claim radius); 0 = none
  // (TrackingStepOptions::exclude_claimed_radius 0).
  float claimed_margin = 0.f;
  // The ObjectManager's threads ([1, 64]): the segmentation and the parts of a frame's born clusters side by side;
  // the output is the same for every count.
  int threads = 1;

  // Throws std::invalid_argument naming the field and its range.
  void validate() const;
};

// A frame the merger finished: its scene, what ObjectManager made of it and every object now.
struct FinishedFrame {
  const Scene& scene;
  const ObjectManagerFrame& result;
  const std::map<std::int32_t, ManagedObject>& objects;
  std::chrono::steady_clock::time_point due_at;  // when the core began to finish it (its clock)
};

class MergerSink {
 public:
  MergerSink() = default;
  MergerSink(const MergerSink&) = delete;
  MergerSink& operator=(const MergerSink&) = delete;
  virtual ~MergerSink() = default;

  // The object's model and pose as of frame `frame_seq`, addressed to `worker_id` (its owner, or
  // -1: nobody owns it now) and that worker's process `worker_instance` (0 when unknown), with what
  // the other objects claim near it (ObjectManager::claimed_points; empty when not asked for), for
  // worker `recipient` (>= 0: the addressee, or a worker that holds the object without owning it).
  // `held`: the version of the model this owner was sent last (nullptr: send the whole model); the sink
  // may send the model as an edit of it, without the claimed points: the frame_done_t that follows this
  // call within the frame carries them.
  virtual void send_model(const ManagedObject& object, std::int32_t worker_id, std::int64_t worker_instance,
                          std::int64_t frame_seq, std::span<const Eigen::Vector3f> claimed, std::int32_t recipient,
                          const HeldModel* held) = 0;
  // The object is gone, as of frame `frame_seq`; for worker `recipient` (>= 0), which holds it.
  virtual void send_retirement(std::int32_t object_id, std::int64_t frame_seq, std::int32_t recipient) = 0;
  // The frame's end, for every worker; the sink stamps its utime.
  virtual void send_frame_done(frame_done_t& message) = 0;
  // Asks worker `worker_id`, process `worker_instance`, for the model of `object_id`, which it holds
  // and this (restarted) merger does not know (ObjectResumer; MFOT_MODEL_REQUEST).
  virtual void request_model(std::int32_t object_id, std::int32_t worker_id, std::int64_t worker_instance) = 0;
  // A scene as received, for workers that lost it.
  virtual void resend_scene(std::span<const std::uint8_t> message) = 0;
  virtual void publish_frame(const FinishedFrame& frame) = 0;
  // Something a person watching the status should know (late scenes and the like).
  virtual void note(const std::string& message) = 0;
};

class MergerCore {
 public:
  using Clock = std::chrono::steady_clock;

  // `malformed` counts the messages refused; `clock` gives the current time.
  MergerCore(MergerCoreOptions options, MergerSink& sink, MalformedCounter& malformed,
             std::function<Clock::time_point()> clock);
  MergerCore(const MergerCore&) = delete;
  MergerCore& operator=(const MergerCore&) = delete;

  // The subscribers (MFOT_SCENE, MFOT_ESTIMATE, MFOT_HEARTBEAT): malformed messages are counted
  // and dropped.
  void on_scene(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name);
  void on_estimate(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name);
  void on_heartbeat(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name);
  // MFOT_MODEL_REPORT: a worker's answer to request_model (ObjectResumer): taken when it answers a
  // pending request with a valid model, the object then resumed under its id with its owner;
  // anything else is counted as malformed and dropped.
  void on_model_report(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name);

  // Steps 1-3; returns the number of frames finished.
  int step();

  const ObjectManager& manager() const { return manager_; }
  const WorkerPool& workers() const { return workers_; }
  std::size_t open_frames() const { return frames_.open_frames(); }
  const ObjectResumer& resumer() const { return resumer_; }

 private:
  void assign_idle_workers(Clock::time_point now);
  // `as_edit`: the frame's end follows, so the model may go as an edit of the version the owner was sent last.
  void send_model(std::int32_t object_id, std::int32_t worker_id, std::int64_t frame_seq, std::int32_t recipient,
                  bool as_edit = false);
  void finish_frame(Clock::time_point due_at);
  void send_frame_done(std::int64_t frame_seq);

  // The model last sent to an object's owner: a new owner, process or version is sent again (a new
  // version as an edit of `cloud`).
  struct ModelSent {
    std::int32_t worker_id;
    std::int64_t worker_instance;
    std::int32_t version;
    ColoredCloud cloud;  // that version's points, object frame
  };

  ObjectManager manager_;
  WorkerPool workers_;
  FrameAssembler frames_;
  ObjectResumer resumer_;
  MergerSink& sink_;
  MalformedCounter& malformed_;
  std::function<Clock::time_point()> clock_;
  float claimed_margin_;                           // MergerCoreOptions::claimed_margin
  std::vector<std::int32_t> object_ids_;           // scratch: the objects in id order
  std::vector<Eigen::Vector3f> claimed_;           // scratch: what the other objects claim near one
  std::map<std::int32_t, ModelSent> models_sent_;  // by object id
  frame_done_t frame_done_;                        // reused every frame
};

}  // namespace mfot::service
