#pragma once
// Group identity and authentication of LCM messages (issue 55), free of any transport: it works on
// encoded messages (lcm-gen bytes) and is unit-tested without sockets.
//
// Every top-level type in lcmtypes/ has envelope_t as its second field, right after utime, so the
// envelope sits at one fixed wire offset in all of them: fingerprint 8 | utime 8 | group_id 8 |
// sender 8 | sequence 8 | mac 32. stamp() fills it in an encoded message; verify() checks a
// received one:
//   - group_id not ours                          -> kForeign  (another group on this URL)
//   with a key (group.key_file):
//   - HMAC-SHA256 over the message with mac zeroed wrong -> kForged
//   - sequence not above the last accepted from that sender on that channel -> kReplayed
// Without a key only the group is checked (anyone on the network can then still forge messages).

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

namespace mfot::service {

namespace envelope {
inline constexpr std::size_t kOffset = 16;  // after the 8-byte fingerprint and utime
inline constexpr std::size_t kGroupOffset = 16;
inline constexpr std::size_t kSenderOffset = 24;
inline constexpr std::size_t kSequenceOffset = 32;
inline constexpr std::size_t kMacOffset = 40;
inline constexpr std::size_t kMacBytes = 32;
inline constexpr std::size_t kEnd = 72;  // a message shorter than this has no envelope
}  // namespace envelope

// group.id's range: positive and exactly representable as a double (Python, YAML, JSON tools).
inline constexpr std::int64_t kMaxGroupId = (std::int64_t{1} << 53);
// group.key_file's contents: at least 32 bytes (256 bits, HMAC-SHA256's block of strength), at most 4096.
inline constexpr std::size_t kMinKeyBytes = 32;
inline constexpr std::size_t kMaxKeyBytes = 4096;
// Senders whose last sequence is remembered per channel; beyond it the least recently heard is forgotten
// (only senders with the key, or any sender without one, get this far).
inline constexpr std::size_t kMaxRememberedSenders = 4096;

enum class Verdict { kAccepted, kNoEnvelope, kForeign, kForged, kReplayed };
const char* verdict_name(Verdict verdict);

struct AuthCounts {
  std::int64_t foreign = 0;
  std::int64_t forged = 0;
  std::int64_t replayed = 0;
};

// Reads a group key: the whole file, which must be a regular file that neither group nor others
// may read or write (mode & 077 == 0) and hold kMinKeyBytes..kMaxKeyBytes bytes; throws ConfigError
// naming the path and the problem.
std::vector<std::uint8_t> load_group_key(const std::string& path);

class MessageAuthenticator {
 public:
  // `key` empty: no authentication (group check only). `sender`: this process, > 0.
  MessageAuthenticator(std::int64_t group_id, std::int64_t sender, std::vector<std::uint8_t> key);

  std::int64_t group_id() const { return group_id_; }
  std::int64_t sender() const { return sender_; }
  bool authenticated() const { return !key_.empty(); }

  // Fills the envelope of an encoded message in place: group id, sender, the next sequence, MAC.
  // Returns false (leaving it unchanged) when it is shorter than envelope::kEnd.
  bool stamp(std::uint8_t* data, std::size_t size);
  bool stamp(std::vector<std::uint8_t>& message) { return stamp(message.data(), message.size()); }

  // Checks a received encoded message at `now_utime` (microseconds since the epoch); counts what it
  // drops (kNoEnvelope is left to the caller: such a message is malformed). With a key and a
  // max_age_us > 0, a message whose utime is further than that from now is a replay too (a recorded
  // message played to a receiver that never heard its sender, e.g. after a restart).
  Verdict verify(const std::string& channel, const std::uint8_t* data, std::size_t size, std::int64_t now_utime);
  Verdict verify(const std::string& channel, const std::vector<std::uint8_t>& message, std::int64_t now_utime) {
    return verify(channel, message.data(), message.size(), now_utime);
  }
  void set_max_age_us(std::int64_t max_age_us) { max_age_us_ = max_age_us; }

  AuthCounts counts() const;

 private:
  void mac(const std::uint8_t* data, std::size_t size, std::uint8_t out[envelope::kMacBytes]) const;

  const std::int64_t group_id_;
  const std::int64_t sender_;
  const std::vector<std::uint8_t> key_;
  struct MacAlgorithm;
  std::shared_ptr<MacAlgorithm> algorithm_;  // OpenSSL's HMAC, fetched once
  mutable std::mutex mutex_;
  std::int64_t max_age_us_ = 0;
  std::int64_t next_sequence_ = 1;
  AuthCounts counts_;
  std::uint64_t clock_ = 0;  // verify() calls, for forgetting the least recently heard sender
  struct Seen {
    std::int64_t sequence;
    std::uint64_t heard;
  };
  std::map<std::pair<std::int64_t, std::string>, Seen> last_;
};

}  // namespace mfot::service
