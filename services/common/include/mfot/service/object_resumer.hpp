#pragma once
// How a restarted merger resumes the objects its tracker workers still hold, transport-free: ids,
// models, poses and owners stay what they were, so controllers see the same ids after a restart.
// Protocol (the clock is passed in; MergerCore drives it):
//   1. start-up: the merger finishes no frame for `listen` after it started (every worker
//      heartbeats within it and says which object it holds), nor while a request is pending;
//   2. within `listen`, a live worker's heartbeat names an object the merger does not know: the
//      merger asks that worker, process and object (MFOT_MODEL_REQUEST); one request per object
//      (the first worker to claim it), at most kMaxPendingRequests at a time, ids in
//      [1, kMaxObjectId] only. No request is made after `listen`, so frames wait at most
//      listen + report_timeout, whatever heartbeats arrive;
//   3. the worker answers with the object's model, version and last pose (MFOT_MODEL_REPORT); a
//      report is taken only when it answers a pending request (same object, worker and process, not
//      timed out) and carries a valid model (1 .. max_model_points finite points within
//      kMaxModelRadius, a unit quaternion, a version >= 0): nobody can make the merger adopt an
//      object it did not ask for, or one without a model;
//   4. a request unanswered for `report_timeout` is given up: the object is retired as before;
//   5. resumption closes for good when the merger finishes its first frame: after that an unknown
//      held object is one this merger retired (or a stranger's), and is retired.
// What is taken becomes ObjectManager::resume_object plus WorkerPool::resume_owner in MergerCore.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <variant>

#include "mfot/object_manager.hpp"
#include "mfot/object_model_t.hpp"

namespace mfot::service {

struct ObjectResumerOptions {
  // Frames wait this long after start-up for the workers' heartbeats, and requests are made only
  // within it (merger.resume_listen_ms, [0, 10 s]; 0 = resumption off).
  std::chrono::milliseconds listen{0};
  // A request unanswered this long is given up (merger.resume_timeout_ms, [1 ms, 10 s]).
  std::chrono::milliseconds report_timeout{500};
  // A reported model holds at most this many points (merger.max_model_points).
  std::size_t max_model_points = 1500;

  // Throws std::invalid_argument naming the field and its range.
  void validate() const;
};

class ObjectResumer {
 public:
  using Clock = std::chrono::steady_clock;
  // Requests pending at once, at most (one per worker in any real group; a flood of forged
  // heartbeats cannot grow the table beyond it).
  static constexpr std::size_t kMaxPendingRequests = 1024;

  struct Request {
    std::int32_t object_id;
    std::int32_t worker_id;
    std::int64_t worker_instance;
  };
  // A report taken: the object to resume (ObjectManager::resume_object) and its owner.
  struct Resumed {
    ManagedObject object;
    std::int32_t worker_id;
    std::int64_t frame_seq;  // the last frame the worker finished
  };

  // `started`: when the merger started (its clock).
  ObjectResumer(ObjectResumerOptions options, Clock::time_point started);

  // Step 2: live worker `worker_id` (process `instance`) heartbeats holding `object_id`, which the
  // merger does not know. The request to send, or nullopt: resumption closed, `listen` over, the id
  // out of range, already asked (of this or another worker), or too many pending.
  std::optional<Request> held_unknown(std::int32_t worker_id, std::int64_t instance, std::int32_t object_id,
                                      Clock::time_point now);
  // Whether a request for `object_id` waits for its answer (its retirement waits too).
  bool pending(std::int32_t object_id, Clock::time_point now) const;
  // Step 3: the object to resume, or the reason the report is refused.
  std::variant<Resumed, std::string> take_report(const object_model_t& report, Clock::time_point now);
  // Step 1: whether frames must wait now. Timed-out requests are forgotten here (step 4).
  bool holds_frames(Clock::time_point now);
  // Step 5: the first frame was finished.
  void close();
  bool open() const { return open_; }
  std::size_t pending_count() const { return pending_.size(); }
  std::int64_t resumed() const { return resumed_; }

 private:
  struct Pending {
    std::int32_t worker_id;
    std::int64_t instance;
    Clock::time_point asked_at;
  };
  ObjectResumerOptions options_;
  Clock::time_point listen_until_;
  bool open_ = true;
  std::map<std::int32_t, Pending> pending_;  // object -> who was asked
  std::int64_t resumed_ = 0;
};

}  // namespace mfot::service
