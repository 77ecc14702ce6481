#pragma once
// A validating reader of LCM event logs (lcm-logger's files), transport-free. Every event header is
// checked before anything is allocated: the sync word, a channel length in [1, max_channel_bytes], a
// data length in [0, max_data_bytes], and both against the bytes left in the file. A log that ends
// inside an event, or holds a bad header, is reported with the byte offset of that event; a file that
// does not start with the sync word is named as not an LCM log.
//
// LCM's own reader (lcm::LogFile, lcm_eventlog_read_next_event in LCM 1.3) cannot be trusted with such
// files: it skips silently to the next sync word, ends quietly at a truncated event as if at the end,
// and allocates whatever length a header claims (a data length of 0x7fffffff crashes it).
//
// Event layout (big-endian): uint32 sync 0xEDA1DA01 | int64 event number | int64 utime |
// int32 channel length | int32 data length | channel (no NUL) | data.

#include <cstdint>
#include <cstdio>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace mfot::service {

inline constexpr std::uint32_t kLcmLogSync = 0xEDA1DA01u;
inline constexpr std::int64_t kLcmLogHeaderBytes = 28;

struct LcmLogLimits {
  // LCM 1.3's reader asserts a channel length under 1000 bytes.
  std::int32_t max_channel_bytes = 999;
  // As LCM's UDP transport and mfot_lcm.py: no message is larger.
  std::int32_t max_data_bytes = 256 * 1024 * 1024;
};

// A log that cannot be opened or read, or does not hold valid events. offset(): the byte where the
// offending event (or the file) starts.
class LcmLogError : public std::runtime_error {
 public:
  LcmLogError(const std::string& what, std::int64_t offset) : std::runtime_error(what), offset_(offset) {}
  std::int64_t offset() const { return offset_; }

 private:
  std::int64_t offset_;
};

struct LcmLogEvent {
  std::int64_t offset = 0;  // of its header in the file
  std::int64_t event_number = 0;
  std::int64_t utime = 0;
  std::string channel;
  std::vector<std::uint8_t> data;
};

class LcmLogReader {
 public:
  // Throws LcmLogError naming the path when it cannot be opened, is empty, or does not start with
  // the sync word ("not an LCM log").
  explicit LcmLogReader(std::string path, LcmLogLimits limits = {});

  // The next event; nullopt exactly at the end of the file. Throws LcmLogError (path, byte offset,
  // what is wrong) on a truncated or corrupt event; the reader then stays at that event.
  std::optional<LcmLogEvent> next();
  // Back to the first event.
  void rewind();

  const std::string& path() const { return path_; }
  std::int64_t offset() const { return offset_; }  // of the next event
  std::int64_t size() const { return size_; }
  std::int64_t events_read() const { return events_; }

 private:
  [[noreturn]] void fail(const std::string& what) const;
  void read_exact(void* out, std::int64_t bytes);

  std::string path_;
  LcmLogLimits limits_;
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file_;
  std::int64_t size_ = 0;
  std::int64_t offset_ = 0;
  std::int64_t events_ = 0;
};

}  // namespace mfot::service
