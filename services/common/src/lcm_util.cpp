#include "mfot/service/lcm_util.hpp"

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdlib>

#include "mfot/frame_done_t.hpp"
#include "mfot/frame_t.hpp"
#include "mfot/heartbeat_t.hpp"
#include "mfot/object_model_t.hpp"
#include "mfot/poses_t.hpp"
#include "mfot/scene_cloud_t.hpp"
#include "mfot/segmentation_t.hpp"
#include "mfot/service/message_authenticator.hpp"

namespace mfot::service {

std::string lcm_url(const std::string& configured) {
  if (!configured.empty()) return configured;
  if (const char* env = std::getenv("MFOT_LCM_URL"); env != nullptr && *env != '\0') return env;
  if (const char* env = std::getenv("LCM_DEFAULT_URL"); env != nullptr && *env != '\0') return env;
  return kDefaultLcmUrl;
}

std::int64_t now_utime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::string host_name() {
  char name[256] = {};
  if (gethostname(name, sizeof(name) - 1) != 0 || name[0] == '\0') return "unknown";
  return name;
}

std::int64_t process_instance() {
  // Microseconds at start in the high bits, the process id in the low 20: two processes started on
  // one host differ in the pid, on two hosts (almost surely) in the time.
  static const std::int64_t instance = (now_utime() << 20) ^ static_cast<std::int64_t>(getpid() & 0xFFFFF);
  return instance;
}

void MalformedCounter::record(const std::string& channel, const std::string& kind, const std::string& detail) {
  std::lock_guard lock(mutex_);
  const auto n = ++counts_[{channel, kind}];
  ++total_;
  last_ = channel + ": " + kind + ": " + detail;
  if (n == 1) {
    spdlog::warn("malformed message on {} ({}): {}; dropped (further ones of this kind are only counted)", channel,
                 kind, detail);
  }
}

std::int64_t MalformedCounter::total() const {
  std::lock_guard lock(mutex_);
  return total_;
}

std::string MalformedCounter::last() const {
  std::lock_guard lock(mutex_);
  return last_;
}

namespace {
std::shared_ptr<MessageAuthenticator> g_authenticator;
std::mutex g_publish_mutex;
std::mutex g_rejected_mutex;
std::map<std::pair<std::string, Verdict>, std::int64_t> g_rejected;  // first of each logged
}  // namespace

void install_message_authenticator(std::shared_ptr<MessageAuthenticator> authenticator) {
  g_authenticator = std::move(authenticator);
}

MessageAuthenticator* message_authenticator() { return g_authenticator.get(); }

int publish_encoded(lcm::LCM& lcm, const std::string& channel, std::vector<std::uint8_t> message) {
  std::lock_guard lock(g_publish_mutex);
  if (g_authenticator && !g_authenticator->stamp(message)) {
    spdlog::error("not publishing {} bytes on {}: too short for an envelope", message.size(), channel);
    return -1;
  }
  return lcm.publish(channel, message.data(), static_cast<unsigned>(message.size()));
}

bool message_is_authentic(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name,
                          MalformedCounter& malformed) {
  MessageAuthenticator* auth = g_authenticator.get();
  if (auth == nullptr) return true;
  const Verdict verdict =
      auth->verify(channel_name, static_cast<const std::uint8_t*>(rbuf->data), rbuf->data_size, now_utime());
  if (verdict == Verdict::kAccepted) return true;
  if (verdict == Verdict::kNoEnvelope) {
    malformed.record(channel_name, "undecodable",
                     "too short for a message (" + std::to_string(rbuf->data_size) + " bytes)");
    return false;
  }
  std::lock_guard lock(g_rejected_mutex);
  if (++g_rejected[{channel_name, verdict}] == 1) {
    spdlog::warn("{} message on {} dropped ({}); further ones are only counted (service_status_t)",
                 verdict_name(verdict), channel_name,
                 verdict == Verdict::kForeign  ? "another group's id"
                 : verdict == Verdict::kForged ? "wrong MAC: not signed with this group's key"
                                               : "sequence not above the sender's last, or too old");
  }
  return false;
}

namespace {

// Every top-level type carries envelope_t (56 bytes on the wire: group_id, sender, sequence, mac[4])
// right after utime; the offsets below are those without it plus kEnvelopeBytes.
constexpr std::size_t kEnvelopeBytes = 56;

// A message being checked against the wire layout of type T (big-endian, 8-byte fingerprint
// first, lcmtypes/*.lcm). Offsets below count the fields before each array count.
class WireLayout {
 public:
  WireLayout(const lcm::ReceiveBuffer* rbuf, std::int64_t fingerprint)
      : data_(static_cast<const std::uint8_t*>(rbuf->data)), size_(rbuf->data_size) {
    std::int64_t hash = 0;
    ours_ = read(0, 8, hash) && hash == fingerprint;
  }
  bool ours() const { return ours_; }
  // The int32 at `offset`; false when the buffer ends first.
  bool int32_at(std::size_t offset, std::int64_t& value) const { return read(offset, 4, value); }
  // False when `count` elements of at least `element_bytes` each cannot fit after `offset`.
  bool fits(std::size_t offset, std::int64_t count, std::size_t element_bytes) const {
    return count <= 0 || (offset <= size_ && static_cast<std::uint64_t>(count) <= (size_ - offset) / element_bytes);
  }

 private:
  bool read(std::size_t offset, std::size_t bytes, std::int64_t& value) const {
    if (offset > size_ || size_ - offset < bytes) return false;
    std::uint64_t bits = 0;
    for (std::size_t i = 0; i < bytes; ++i) bits = (bits << 8) | data_[offset + i];
    value = bytes == 4 ? static_cast<std::int32_t>(static_cast<std::uint32_t>(bits)) : static_cast<std::int64_t>(bits);
    return true;
  }
  const std::uint8_t* data_;
  std::size_t size_;
  bool ours_ = false;
};

// One array count at a fixed offset, each element at least `element_bytes` on the wire.
bool fixed_count_fits(const lcm::ReceiveBuffer* rbuf, std::int64_t fingerprint, std::size_t count_offset,
                      std::size_t element_bytes) {
  const WireLayout wire(rbuf, fingerprint);
  std::int64_t count = 0;
  if (!wire.ours() || !wire.int32_at(count_offset, count)) return true;
  return wire.fits(count_offset + 4, count, element_bytes);
}

}  // namespace

// hash 8 | utime, frame_seq, capture_utime 24 | width, height 8 | fx, fy, cx, cy, voxel_size 20 |
// voxel_origin 12 | plane 16 | num_points; per point x, y, z 12 + r, g, b 3 + u, v 4 + cluster 4.
bool declared_sizes_fit(const lcm::ReceiveBuffer* rbuf, const scene_cloud_t*) {
  return fixed_count_fits(rbuf, scene_cloud_t::getHash(), 88 + kEnvelopeBytes, 23);
}

// hash 8 | utime, frame_seq 16 | object_id, worker_id 8 | worker_instance 8 | version 4 | position,
// orientation, velocity 104 | carried_by 4 | companion, companion_motion 52 | is_delta 1 | base_version,
// num_base_points 8 | num_base_runs; per run 4 | num_order_runs; per run 4 | num_points; per point x, y, z 12 +
// r, g, b 3 | num_claimed; per claimed point x, y, z 12.
bool declared_sizes_fit(const lcm::ReceiveBuffer* rbuf, const object_model_t*) {
  const WireLayout wire(rbuf, object_model_t::getHash());
  if (!wire.ours()) return true;
  std::size_t offset = 213 + kEnvelopeBytes;
  for (const std::size_t element_bytes : {std::size_t{4}, std::size_t{4}, std::size_t{15}, std::size_t{12}}) {
    std::int64_t count = 0;
    if (!wire.int32_at(offset, count)) return true;  // decode finds it truncated
    if (!wire.fits(offset + 4, count, element_bytes)) return false;
    offset += 4 + static_cast<std::size_t>(std::max<std::int64_t>(count, 0)) * element_bytes;
  }
  return true;
}

// hash 8 | utime 8 | worker_id 4 | instance 8 | host (int32 length incl. NUL, bytes) | object_id,
// last_frame_seq 12.
bool declared_sizes_fit(const lcm::ReceiveBuffer* rbuf, const heartbeat_t*) {
  const WireLayout wire(rbuf, heartbeat_t::getHash());
  std::int64_t host_length = 0;
  if (!wire.ours() || !wire.int32_at(28 + kEnvelopeBytes, host_length)) return true;
  return host_length >= 1 && wire.fits(32 + kEnvelopeBytes, host_length, 1);
}

// hash 8 | utime, frame_seq 16 | num_points; per point label 4.
bool declared_sizes_fit(const lcm::ReceiveBuffer* rbuf, const segmentation_t*) {
  return fixed_count_fits(rbuf, segmentation_t::getHash(), 24 + kEnvelopeBytes, 4);
}

// hash 8 | utime, frame_seq, capture_utime 24 | num_objects; per object_pose_t id 4 + ten
// double vectors 208 + confidence 4 + stale 1.
bool declared_sizes_fit(const lcm::ReceiveBuffer* rbuf, const poses_t*) {
  return fixed_count_fits(rbuf, poses_t::getHash(), 32 + kEnvelopeBytes, 217);
}

// hash 8 | utime 8 | envelope 56 | frame_seq 8 | num_objects; per frame_done_object_t: object_id, worker_id 8 |
// worker_instance 8 | version 4 | position, orientation 56 | carried_by, companion 8 | companion_motion 48 |
// num_claimed; per claimed point x, y, z 12.
bool declared_sizes_fit(const lcm::ReceiveBuffer* rbuf, const frame_done_t*) {
  constexpr std::size_t kObjectFixed = 132;
  const WireLayout wire(rbuf, frame_done_t::getHash());
  std::int64_t objects = 0;
  if (!wire.ours() || !wire.int32_at(24 + kEnvelopeBytes, objects)) return true;
  if (!wire.fits(28 + kEnvelopeBytes, objects, kObjectFixed + 4)) return false;
  std::size_t offset = 28 + kEnvelopeBytes;
  for (std::int64_t k = 0; k < objects; ++k) {
    std::int64_t claimed = 0;
    if (!wire.int32_at(offset + kObjectFixed, claimed)) return true;
    if (!wire.fits(offset + kObjectFixed + 4, claimed, 12)) return false;
    offset += kObjectFixed + 4 + 12 * static_cast<std::size_t>(std::max<std::int64_t>(claimed, 0));
  }
  return true;
}

// hash 8 | utime, capture_utime, seq 24 | source (int32 length incl. NUL, bytes) | width, height,
// fx, fy, cx, cy 24 | depth_encoding 1 | depth_size, depth bytes | color_encoding 1 | color_size,
// colour bytes.
bool declared_sizes_fit(const lcm::ReceiveBuffer* rbuf, const frame_t*) {
  const WireLayout wire(rbuf, frame_t::getHash());
  std::int64_t source_length = 0;
  if (!wire.ours() || !wire.int32_at(32 + kEnvelopeBytes, source_length)) return true;
  // The length counts the string's NUL, so it is >= 1; lcm-gen computes length - 1 in int, which
  // overflows for INT32_MIN (found by tests/fuzz/fuzz_frame_decoder.cpp).
  if (source_length < 1) return false;
  const std::size_t depth_offset = 36 + kEnvelopeBytes + static_cast<std::size_t>(source_length) + 25;
  std::int64_t depth_size = 0;
  if (!wire.int32_at(depth_offset, depth_size)) return true;
  if (!wire.fits(depth_offset + 4, depth_size, 1)) return false;
  const std::size_t color_offset =
      depth_offset + 4 + static_cast<std::size_t>(std::max<std::int64_t>(depth_size, 0)) + 1;
  std::int64_t color_size = 0;
  if (!wire.int32_at(color_offset, color_size)) return true;
  return wire.fits(color_offset + 4, color_size, 1);
}

namespace {
std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop.store(true); }
}  // namespace

void install_signal_handlers() {
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
}
bool stop_requested() { return g_stop.load(); }
void request_stop() { g_stop.store(true); }

bool handle_for(lcm::LCM& lcm, int timeout_ms) { return lcm.handleTimeout(timeout_ms) >= 0; }

void setup_logging(const std::string& service, int instance) {
  spdlog::set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ [" + service + "/" + std::to_string(instance) + "] %v");
  if (const char* level = std::getenv("MFOT_LOG_LEVEL"); level != nullptr) {
    spdlog::set_level(spdlog::level::from_str(level));
  }
}

}  // namespace mfot::service
