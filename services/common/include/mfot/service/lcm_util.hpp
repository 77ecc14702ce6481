#pragma once
// LCM plumbing shared by every service: channel names, the transport URL, validated decoding,
// signal handling and logging set-up.

#include <cstdint>
#include <exception>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "mfot/types.hpp"

namespace mfot {
class frame_done_t;
class frame_t;
class heartbeat_t;
class object_model_t;
class poses_t;
class scene_cloud_t;
class segmentation_t;
}  // namespace mfot

namespace mfot::service {

class MessageAuthenticator;

namespace channel {
inline constexpr const char* kFrame = "MFOT_FRAME";  // frame_t, capture -> preprocess, merger
inline constexpr const char* kScene = "MFOT_SCENE";  // scene_cloud_t, preprocess -> trackers, merger
// object_model_t, merger -> one tracker: MFOT_MODEL_<worker_id> (model_channel), so a worker receives
// and decodes only the models addressed to it; the merger sends a model when it changes or is (re)assigned.
inline constexpr const char* kModelPrefix = "MFOT_MODEL_";
inline constexpr const char* kFrameDone = "MFOT_FRAME_DONE";       // frame_done_t, merger -> trackers, every frame
inline constexpr const char* kEstimate = "MFOT_ESTIMATE";          // tracker_estimate_t, trackers -> merger
inline constexpr const char* kPoses = "MFOT_POSES";                // poses_t, merger -> controllers (and lockstep)
inline constexpr const char* kSegmentation = "MFOT_SEGMENTATION";  // segmentation_t, merger -> anyone
inline constexpr const char* kHeartbeat = "MFOT_HEARTBEAT";        // heartbeat_t, trackers -> merger
// A restarted merger asks a worker for the object it still holds (object_model_t without points,
// merger -> trackers); the worker answers with that object's model and last pose (object_model_t,
// tracker -> merger). See ObjectResumer.
inline constexpr const char* kModelRequest = "MFOT_MODEL_REQUEST";
inline constexpr const char* kModelReport = "MFOT_MODEL_REPORT";
inline constexpr const char* kStatus = "MFOT_STATUS";  // service_status_t, every service
// The channel of the models for worker `worker_id` (>= 0).
inline std::string model_channel(std::int32_t worker_id) { return kModelPrefix + std::to_string(worker_id); }
}  // namespace channel

// Ranges of received ids (issue 55), checked where messages arrive so that no value can overflow a
// counter: object ids received are 1..kMaxObjectId (the core's, mfot/types.hpp; a heartbeat or model
// naming another is dropped and counted as malformed), worker ids 0..kMaxWorkerId (mfot-tracker
// --worker-id's range).
inline constexpr std::int32_t kMaxWorkerId = 100000;

// Lockstep sources (mfot-capture, also replaying a log) keep at most this many frames out whose poses have
// not come back (capture.lockstep_window). One: a frame's latency is its own processing time (more
// frames in flight raise throughput, since preprocessing of the next frame overlaps tracking and
// merging of this one, but each frame then also waits for those ahead of it); the results are the
// same for every window, since trackers wait for the models of the frame before (TrackerSceneQueue).
inline constexpr int kDefaultLockstepWindow = 1;
inline constexpr int kMaxLockstepWindow = 8;

// Host-local multicast: ttl=0 keeps traffic on this machine (LCM has no authentication).
inline constexpr const char* kDefaultLcmUrl = "udpm://239.255.76.67:7667?ttl=0";

// `configured` if not empty, else $MFOT_LCM_URL (the process group's), else $LCM_DEFAULT_URL, else
// kDefaultLcmUrl.
std::string lcm_url(const std::string& configured);

// This machine's host name ("unknown" when it has none), for status and heartbeats.
std::string host_name();
// Identifies this process among all that ever heartbeat (start time and process id); the same for
// every call.
std::int64_t process_instance();

std::int64_t now_utime();

// Counts malformed messages; logs the first of each (channel, kind) and stays quiet afterwards.
class MalformedCounter {
 public:
  void record(const std::string& channel, const std::string& kind, const std::string& detail);
  std::int64_t total() const;
  std::string last() const;

 private:
  mutable std::mutex mutex_;
  std::map<std::pair<std::string, std::string>, std::int64_t> counts_;
  std::int64_t total_ = 0;
  std::string last_;
};

// The process's MessageAuthenticator (message_authenticator.hpp): every service installs one at start
// (install_group_security, group_security.hpp); publish_message stamps with it and decode_message
// verifies with it. None installed (unit tests, tools): messages go out unstamped and all are accepted.
void install_message_authenticator(std::shared_ptr<MessageAuthenticator> authenticator);
MessageAuthenticator* message_authenticator();

// Stamps an encoded message (when an authenticator is installed) and publishes it; lcm's result (0 = sent).
// Stamping and sending hold one lock, so one process's messages leave in sequence order.
int publish_encoded(lcm::LCM& lcm, const std::string& channel, std::vector<std::uint8_t> message);

// Encodes, stamps and publishes an lcm-gen message: what every service publishes goes through here.
template <class T>
int publish_message(lcm::LCM& lcm, const std::string& channel, const T& message) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(message.getEncodedSize()));
  if (message.encode(bytes.data(), 0, static_cast<int>(bytes.size())) != static_cast<int>(bytes.size())) return -1;
  return publish_encoded(lcm, channel, std::move(bytes));
}

// The installed authenticator's verdict on a received message: true to accept. A foreign, forged or
// replayed one is counted by the authenticator (service_status_t foreign/forged/replayed) and the
// first of each kind per channel logged; one too short for an envelope is counted as malformed.
bool message_is_authentic(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name, MalformedCounter& malformed);

// lcm-gen's decode resizes each array to its declared count before checking that the buffer
// holds the elements, so a 100-byte message declaring num_points = 2e9 would allocate and zero
// gigabytes (which succeeds under Linux overcommit, so catching std::bad_alloc is not enough).
// These read the declared counts of the types with arrays straight from the wire and return false
// when the elements cannot fit in the buffer (or a string length is below 1); they return true
// (leaving it to decode) for a foreign fingerprint or a buffer too short to hold the count.
// Types without arrays need none.
bool declared_sizes_fit(const lcm::ReceiveBuffer* rbuf, const frame_done_t*);
bool declared_sizes_fit(const lcm::ReceiveBuffer* rbuf, const frame_t*);
bool declared_sizes_fit(const lcm::ReceiveBuffer* rbuf, const heartbeat_t*);
bool declared_sizes_fit(const lcm::ReceiveBuffer* rbuf, const object_model_t*);
bool declared_sizes_fit(const lcm::ReceiveBuffer* rbuf, const poses_t*);
bool declared_sizes_fit(const lcm::ReceiveBuffer* rbuf, const scene_cloud_t*);
bool declared_sizes_fit(const lcm::ReceiveBuffer* rbuf, const segmentation_t*);
template <class T>
bool declared_sizes_fit(const lcm::ReceiveBuffer*, const T*) {
  return true;
}

// Decodes an lcm-gen type; a truncated buffer, wrong fingerprint, array count larger than the
// buffer or bytes left over after the message are counted and return false. With `authenticate`
// (all live traffic; not a recorded log's events) the message must first pass message_is_authentic.
template <class T>
bool decode_message(const lcm::ReceiveBuffer* rbuf, const std::string& channel_name, T& out,
                    MalformedCounter& malformed, bool authenticate = true) {
  if (rbuf->data_size > static_cast<std::uint32_t>(INT32_MAX)) {
    malformed.record(channel_name, "oversized", std::to_string(rbuf->data_size) + " bytes");
    return false;
  }
  if (authenticate && !message_is_authentic(rbuf, channel_name, malformed)) return false;
  if (!declared_sizes_fit(rbuf, static_cast<const T*>(nullptr))) {
    malformed.record(
        channel_name, "bad array size",
        "declared array or string sizes do not fit the " + std::to_string(rbuf->data_size) + " message bytes");
    return false;
  }
  int n = -1;
  try {
    n = out.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size));
  } catch (const std::exception& e) {  // a negative or absurd array size
    malformed.record(channel_name, "bad array size", e.what());
    return false;
  }
  if (n < 0) {
    malformed.record(channel_name, "undecodable",
                     "truncated or wrong type fingerprint (" + std::to_string(rbuf->data_size) + " bytes)");
    return false;
  }
  // LCM delivers exactly one encoded message: leftover bytes mean a count field lied.
  if (n != static_cast<int>(rbuf->data_size)) {
    malformed.record(channel_name, "trailing bytes",
                     std::to_string(rbuf->data_size - static_cast<std::uint32_t>(n)) + " bytes after the message");
    return false;
  }
  return true;
}

// SIGINT / SIGTERM set a flag that the service loops poll.
void install_signal_handlers();
bool stop_requested();
void request_stop();

// One lcm.handleTimeout(timeout_ms); returns false when LCM reports an error.
bool handle_for(lcm::LCM& lcm, int timeout_ms);

// Structured logging: "<time> <level> [<service>/<instance>] message".
void setup_logging(const std::string& service, int instance);

}  // namespace mfot::service
