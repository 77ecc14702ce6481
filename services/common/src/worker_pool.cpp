#include "mfot/service/worker_pool.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <stdexcept>
#include <string>

namespace mfot::service {

void WorkerPoolOptions::validate() const {
  if (worker_timeout < std::chrono::milliseconds(100) || worker_timeout > std::chrono::milliseconds(600000)) {
    throw std::invalid_argument("worker_timeout must be in [100, 600000] ms, got " +
                                std::to_string(worker_timeout.count()));
  }
  if (takeover_silence < std::chrono::milliseconds(1) || takeover_silence > worker_timeout) {
    throw std::invalid_argument("takeover_silence must be in [1, worker_timeout] ms, got " +
                                std::to_string(takeover_silence.count()));
  }
  if (model_in_flight < std::chrono::milliseconds(0) || model_in_flight > worker_timeout) {
    throw std::invalid_argument("model_in_flight must be in [0, worker_timeout] ms, got " +
                                std::to_string(model_in_flight.count()));
  }
}

namespace {
std::string clash_text(std::int32_t worker_id, const WorkerPool::Worker& w) {
  return "worker id " + std::to_string(worker_id) + " claimed by two processes (on " + w.host + " and on " +
         w.contender_host + "); the newer is ignored";
}
}  // namespace

WorkerPool::WorkerPool(WorkerPoolOptions options) : options_(options) { options_.validate(); }

WorkerPool::Reply WorkerPool::heartbeat(const Heartbeat& hb, Clock::time_point now,
                                        const std::function<bool(std::int32_t)>& object_exists) {
  Reply reply;
  const std::int32_t worker_id = hb.worker_id;
  const std::int32_t held_object_id = hb.held_object_id;
  const std::int64_t last_frame_seq = hb.last_frame_seq;
  auto [it, inserted] = workers_.try_emplace(worker_id);
  Worker& w = it->second;
  if (!inserted && w.alive && hb.instance != w.instance) {
    if (now - w.last_seen <= options_.takeover_silence) {
      // Another process under a live worker's id: a restart (the old one stays silent from now
      // on) or a clash (the old one heartbeats again). Either way it waits.
      if (w.contender != hb.instance) {
        w.contender = hb.instance;
        w.contender_host = hb.host;
        w.contender_clashes = false;
      }
      w.contender_seen = now;
      if (w.contender_clashes) {
        ++clashes_;
        reply.clash = clash_text(worker_id, w);
      }
      return reply;
    }
    spdlog::info("tracker worker {} restarted (a new process on {})", worker_id, hb.host);
  } else if (!inserted && w.contender != 0 && hb.instance == w.instance &&
             now - w.contender_seen <= options_.takeover_silence) {
    // The holder heartbeats while another process claims its id: they clash. The holder keeps it.
    if (!w.contender_clashes) {
      w.contender_clashes = true;
      spdlog::error(
          "two processes heartbeat as tracker worker {} (on {} and on {}): the newer one is ignored; "
          "give it another --worker-id",
          worker_id, w.host, w.contender_host);
    }
    ++clashes_;
    reply.clash = clash_text(worker_id, w);
  }
  if (hb.instance != w.instance) w.contender = 0;  // the newcomer took over (or the worker is new)
  if (inserted || !w.alive) {
    spdlog::info("tracker worker {} is {} (on {})", worker_id, inserted ? "up" : "back", hb.host);
    w.object_id = -1;
  }
  w.instance = hb.instance;
  w.host = hb.host;
  w.alive = true;
  w.last_seen = now;
  w.last_frame_seq = last_frame_seq;
  if (w.object_id >= 0 && held_object_id == w.object_id) note_progress(w.object_id, last_frame_seq);
  if (held_object_id == w.object_id || now - w.told_at <= options_.model_in_flight) return reply;
  w.told_at = now;
  std::vector<Correction>& corrections = reply.corrections;
  // The worker lost its model (or restarted): send it again.
  if (w.object_id >= 0) {
    spdlog::warn("worker {} does not hold object {}; sending its model again", worker_id, w.object_id);
    corrections.push_back({Correction::Kind::kSendModel, w.object_id, worker_id});
  }
  // The worker holds an object that is not its own (it missed the move or the retirement, or the
  // merger restarted): tell it who owns that object now, or that it is gone.
  if (held_object_id >= 0) {
    if (object_exists(held_object_id)) {
      const std::int32_t holder = owner(held_object_id).value_or(-1);
      spdlog::warn("worker {} still holds object {}; telling it the owner is worker {}", worker_id, held_object_id,
                   holder);
      corrections.push_back({Correction::Kind::kSendModel, held_object_id, holder});
    } else {
      spdlog::warn("worker {} holds object {}, which does not exist; retiring it", worker_id, held_object_id);
      corrections.push_back({Correction::Kind::kRetire, held_object_id, -1});
    }
  }
  return reply;
}

std::vector<std::int32_t> WorkerPool::expire(Clock::time_point now) {
  std::vector<std::int32_t> dead;
  for (auto& [id, w] : workers_) {
    if (!w.alive || now - w.last_seen <= options_.worker_timeout) continue;
    w.alive = false;
    spdlog::warn("tracker worker {} silent for {} ms: declared dead{}", id, options_.worker_timeout.count(),
                 w.object_id >= 0 ? fmt::format("; object {} will be reassigned", w.object_id) : "");
    if (w.object_id >= 0) disown(w.object_id);
    w.object_id = -1;
    dead.push_back(id);
  }
  return dead;
}

std::vector<WorkerPool::Assignment> WorkerPool::assign(std::span<const std::int32_t> object_ids,
                                                       Clock::time_point now) {
  std::vector<Assignment> assigned;
  std::map<std::string, int> held_on_host;  // objects owned by each host's workers
  for (const auto& [object_id, worker_id] : owners_) ++held_on_host[workers_.at(worker_id).host];
  for (const std::int32_t object_id : object_ids) {
    if (owners_.count(object_id)) continue;
    // The idle worker on the host holding the fewest objects, the lowest id among them: objects
    // spread over hosts (one host: the lowest idle id).
    Worker* chosen = nullptr;
    std::int32_t chosen_id = -1;
    for (auto& [worker_id, w] : workers_) {
      if (!w.alive || w.object_id >= 0) continue;
      if (chosen == nullptr || held_on_host[w.host] < held_on_host[chosen->host]) {
        chosen = &w;
        chosen_id = worker_id;
      }
    }
    if (chosen == nullptr) continue;
    chosen->object_id = object_id;
    chosen->told_at = now;
    owners_[object_id] = chosen_id;
    ++held_on_host[chosen->host];
    progress_.erase(object_id);
    spdlog::info("object {} assigned to worker {} on {}", object_id, chosen_id, chosen->host);
    assigned.push_back({object_id, chosen_id});
  }
  return assigned;
}

bool WorkerPool::resume_owner(std::int32_t object_id, std::int32_t worker_id, Clock::time_point now) {
  const auto it = workers_.find(worker_id);
  if (it == workers_.end() || !it->second.alive || it->second.object_id >= 0 || owners_.contains(object_id)) {
    return false;
  }
  it->second.object_id = object_id;
  it->second.told_at = now;
  owners_[object_id] = worker_id;
  progress_.erase(object_id);
  spdlog::info("object {} resumed on worker {} on {}", object_id, worker_id, it->second.host);
  return true;
}

void WorkerPool::release(std::int32_t object_id, Clock::time_point now) {
  const auto it = owners_.find(object_id);
  if (it != owners_.end()) {
    Worker& w = workers_[it->second];
    w.object_id = -1;
    w.told_at = now;
  }
  disown(object_id);
}

void WorkerPool::disown(std::int32_t object_id) {
  owners_.erase(object_id);
  progress_.erase(object_id);
}

void WorkerPool::note_progress(std::int32_t object_id, std::int64_t seq) {
  auto [it, inserted] = progress_.try_emplace(object_id, seq);
  if (!inserted) it->second = std::max(it->second, seq);
}

bool WorkerPool::owns(std::int32_t worker_id, std::int32_t object_id) const {
  const auto it = owners_.find(object_id);
  return it != owners_.end() && it->second == worker_id;
}

std::optional<std::int32_t> WorkerPool::owner(std::int32_t object_id) const {
  const auto it = owners_.find(object_id);
  if (it == owners_.end()) return std::nullopt;
  return it->second;
}

std::optional<std::int64_t> WorkerPool::progress(std::int32_t object_id) const {
  const auto it = progress_.find(object_id);
  if (it == progress_.end()) return std::nullopt;
  return it->second;
}

std::int64_t WorkerPool::instance_of(std::int32_t worker_id) const {
  const auto it = workers_.find(worker_id);
  return it == workers_.end() ? 0 : it->second.instance;
}

int WorkerPool::alive_count() const {
  return static_cast<int>(
      std::count_if(workers_.begin(), workers_.end(), [](const auto& entry) { return entry.second.alive; }));
}

}  // namespace mfot::service
