#include "mfot/service/object_resumer.hpp"

#include <spdlog/spdlog.h>

#include <stdexcept>
#include <string>

#include "mfot/service/convert.hpp"

namespace mfot::service {

void ObjectResumerOptions::validate() const {
  if (listen < std::chrono::milliseconds(0) || listen > std::chrono::milliseconds(10000)) {
    throw std::invalid_argument("resume listen must be in [0, 10000] ms, got " + std::to_string(listen.count()));
  }
  if (report_timeout < std::chrono::milliseconds(1) || report_timeout > std::chrono::milliseconds(10000)) {
    throw std::invalid_argument("resume report_timeout must be in [1, 10000] ms, got " +
                                std::to_string(report_timeout.count()));
  }
  if (max_model_points < 1) throw std::invalid_argument("resume max_model_points must be >= 1");
}

ObjectResumer::ObjectResumer(ObjectResumerOptions options, Clock::time_point started)
    : options_(options), listen_until_(started + options.listen) {
  options_.validate();
}

std::optional<ObjectResumer::Request> ObjectResumer::held_unknown(std::int32_t worker_id, std::int64_t instance,
                                                                  std::int32_t object_id, Clock::time_point now) {
  if (!open_ || now >= listen_until_ || object_id < 1 || object_id > kMaxObjectId) return std::nullopt;
  if (pending(object_id, now)) return std::nullopt;  // asked already: the first claimant answers
  holds_frames(now);                                 // forget timed-out requests first
  if (pending_.size() >= kMaxPendingRequests) return std::nullopt;
  pending_[object_id] = {worker_id, instance, now};
  spdlog::info("worker {} holds object {}, unknown here (a restart): asking for its model", worker_id, object_id);
  return Request{object_id, worker_id, instance};
}

bool ObjectResumer::pending(std::int32_t object_id, Clock::time_point now) const {
  const auto it = pending_.find(object_id);
  return it != pending_.end() && now - it->second.asked_at <= options_.report_timeout;
}

std::variant<ObjectResumer::Resumed, std::string> ObjectResumer::take_report(const object_model_t& report,
                                                                             Clock::time_point now) {
  if (!open_) return std::string("resumption closed (a frame was finished since the start)");
  const auto it = pending_.find(report.object_id);
  if (it == pending_.end() || !pending(report.object_id, now)) {
    return "object " + std::to_string(report.object_id) + " was not asked for (or its request timed out)";
  }
  if (report.worker_id != it->second.worker_id || report.worker_instance != it->second.instance) {
    return "object " + std::to_string(report.object_id) + " was asked of worker " +
           std::to_string(it->second.worker_id) + ", not worker " + std::to_string(report.worker_id) + " (process " +
           std::to_string(report.worker_instance) + ")";
  }
  if (report.num_points < 1 || static_cast<std::size_t>(report.num_points) > options_.max_model_points) {
    return "model of " + std::to_string(report.num_points) + " points, expected [1, " +
           std::to_string(options_.max_model_points) + "]";
  }
  if (report.version < 0) return std::string("negative version");
  if (report.frame_seq < -1) return std::string("frame_seq below -1");
  Resumed resumed{ManagedObject{}, report.worker_id, report.frame_seq};
  ManagedObject& object = resumed.object;
  object.id = report.object_id;
  object.version = report.version;
  if (auto error = model_from_message(report, object.model, object.pose, object.velocity)) return *error;
  pending_.erase(it);
  ++resumed_;
  return resumed;
}

bool ObjectResumer::holds_frames(Clock::time_point now) {
  if (!open_) return false;
  std::erase_if(pending_, [&](const auto& entry) {
    if (now - entry.second.asked_at <= options_.report_timeout) return false;
    spdlog::warn("worker {} did not report object {} within {} ms: it will be retired", entry.second.worker_id,
                 entry.first, options_.report_timeout.count());
    return true;
  });
  return now < listen_until_ || !pending_.empty();
}

void ObjectResumer::close() {
  if (!open_) return;
  open_ = false;
  pending_.clear();
  if (resumed_ > 0) spdlog::info("resumed {} objects from their workers", resumed_);
}

}  // namespace mfot::service
