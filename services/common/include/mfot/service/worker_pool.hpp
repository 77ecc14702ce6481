#pragma once
// The merger's registry of tracker workers: who is alive, which object each one owns, and how far
// each owner got. Objects scale across processes (and hosts) by handing each object to one idle
// worker; a worker that stops heartbeating is declared dead and its object handed to another one
// under the same id, with the last model and pose (the merger sends them).
// Steps, as the merger feeds it what arrives:
//   1. heartbeat: a new (or returning) worker joins the pool idle; a worker that says it holds
//      something other than its assignment, once the assignment had time to arrive, is answered
//      (send its model again, tell it the object's owner, or retire an object that does not exist).
//      A worker id belongs to one process (its instance): a new process under a live worker's id
//      takes it over only once the old one has fallen silent (a restart); while both heartbeat,
//      the ids clash: the newcomer is ignored and the clash reported, never silently shared;
//   2. expire: workers silent for longer than the timeout are declared dead, their objects freed;
//   3. assign: every object without a live owner goes to an idle worker on the host that holds the
//      fewest objects (the lowest id there), so objects spread over the hosts of the group;
//   4. release: a retired object frees its worker.
// The owner's progress (the last frame it finished, from its estimates and heartbeats) lets the
// frame assembly stop waiting for an estimate that will never come.
// No LCM and no clock of its own: the caller passes the time.

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace mfot::service {

struct WorkerPoolOptions {
  // A worker silent this long is declared dead, [100 ms, 600 s] (merger.worker_timeout_ms).
  std::chrono::milliseconds worker_timeout{1000};
  // A model sent to a worker reaches it well within this on one host; a heartbeat that still
  // disagrees with the assignment afterwards means the model (or the retirement) was lost.
  std::chrono::milliseconds model_in_flight{200};
  // A new process under a live worker's id takes it over when the old process has been silent
  // this long (more than two of its 100 ms heartbeats: it was restarted); [1 ms, worker_timeout].
  std::chrono::milliseconds takeover_silence{250};

  // Throws std::invalid_argument naming the field and its range.
  void validate() const;
};

class WorkerPool {
 public:
  using Clock = std::chrono::steady_clock;

  struct Worker {
    std::int64_t instance = 0;  // the process holding this id
    std::string host;           // where it runs
    Clock::time_point last_seen;
    std::int32_t object_id = -1;       // as assigned by the merger
    Clock::time_point told_at;         // when it was last sent its assignment, a move or a retirement
    std::int64_t last_frame_seq = -1;  // from its last heartbeat
    bool alive = true;
    // Another process heartbeating under this id (0 = none), until it takes over or is shown to clash.
    std::int64_t contender = 0;
    std::string contender_host;
    Clock::time_point contender_seen;
    bool contender_clashes = false;  // the holder heartbeated after it appeared: both are alive
  };

  // What the merger must send after a heartbeat that disagrees with the assignment.
  struct Correction {
    enum class Kind {
      kSendModel,  // send object_id's model addressed to worker_id (its owner, or -1 for none)
      kRetire,     // object_id does not exist: retire it (and never reuse its id)
    };
    Kind kind;
    std::int32_t object_id;
    std::int32_t worker_id;
  };

  struct Assignment {
    std::int32_t object_id;
    std::int32_t worker_id;
  };

  struct Heartbeat {
    std::int32_t worker_id;
    std::int64_t instance;
    std::string host;
    std::int32_t held_object_id;  // -1 = none
    std::int64_t last_frame_seq;  // -1 = none
  };

  struct Reply {
    std::vector<Correction> corrections;
    // Another process heartbeats under this live worker's id: it is ignored (say so).
    std::optional<std::string> clash;
  };

  explicit WorkerPool(WorkerPoolOptions options);
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  // Step 1. `object_exists` answers for an object the worker holds but does not own.
  Reply heartbeat(const Heartbeat& heartbeat, Clock::time_point now,
                  const std::function<bool(std::int32_t)>& object_exists);
  // Step 2: the workers declared dead now.
  std::vector<std::int32_t> expire(Clock::time_point now);
  // Step 3, over `object_ids` in order; returns the new assignments.
  std::vector<Assignment> assign(std::span<const std::int32_t> object_ids, Clock::time_point now);
  // A restarted merger resumed `object_id`, which live idle worker `worker_id` still holds: it owns it
  // again (no model goes out: the worker has it). False (nothing changed) when the worker is unknown,
  // dead, owns something, or the object has an owner.
  bool resume_owner(std::int32_t object_id, std::int32_t worker_id, Clock::time_point now);
  // Step 4: the object is gone; its owner (if any) becomes idle.
  void release(std::int32_t object_id, Clock::time_point now);

  // The owner has finished frame `seq` of its object (an estimate or a heartbeat).
  void note_progress(std::int32_t object_id, std::int64_t seq);
  // Whether `worker_id` owns `object_id` now.
  bool owns(std::int32_t worker_id, std::int32_t object_id) const;
  std::optional<std::int32_t> owner(std::int32_t object_id) const;
  // The process instance holding worker_id (0 when unknown).
  std::int64_t instance_of(std::int32_t worker_id) const;
  // Heartbeats refused because another process holds their worker id, so far.
  std::int64_t clashes() const { return clashes_; }
  // The last frame the owner of `object_id` finished, if it said so.
  std::optional<std::int64_t> progress(std::int32_t object_id) const;
  // object -> worker, in object order.
  const std::map<std::int32_t, std::int32_t>& owners() const { return owners_; }
  const std::map<std::int32_t, Worker>& workers() const { return workers_; }
  int alive_count() const;

 private:
  void disown(std::int32_t object_id);

  WorkerPoolOptions options_;
  std::map<std::int32_t, Worker> workers_;
  std::map<std::int32_t, std::int32_t> owners_;    // object -> worker
  std::map<std::int32_t, std::int64_t> progress_;  // object -> last frame its owner finished
  std::int64_t clashes_ = 0;
};

}  // namespace mfot::service
