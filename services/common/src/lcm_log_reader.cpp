#include "mfot/service/lcm_log_reader.hpp"

#include <fmt/format.h>
#include <sys/stat.h>

#include <array>
#include <cerrno>
#include <cstring>

namespace mfot::service {
namespace {

std::uint32_t be32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | std::uint32_t{p[3]};
}

std::int64_t be64(const std::uint8_t* p) {
  return static_cast<std::int64_t>((std::uint64_t{be32(p)} << 32) | std::uint64_t{be32(p + 4)});
}

std::int64_t file_size(std::FILE* file) {
  struct stat info {};
  if (::fstat(::fileno(file), &info) != 0) return -1;
  return static_cast<std::int64_t>(info.st_size);
}

}  // namespace

LcmLogReader::LcmLogReader(std::string path, LcmLogLimits limits)
    : path_(std::move(path)), limits_(limits), file_(std::fopen(path_.c_str(), "rb"), &std::fclose) {
  if (!file_) throw LcmLogError(path_ + ": cannot open the LCM log: " + std::strerror(errno), 0);
  struct stat info {};
  if (::fstat(::fileno(file_.get()), &info) != 0) fail(std::string("cannot stat: ") + std::strerror(errno));
  if (!S_ISREG(info.st_mode)) fail("not a regular file: not an LCM log");
  size_ = static_cast<std::int64_t>(info.st_size);
  if (size_ == 0) fail("empty (0 bytes): not an LCM log");
  std::array<std::uint8_t, 4> magic{};
  const std::size_t got = std::fread(magic.data(), 1, magic.size(), file_.get());
  if (got < magic.size() || be32(magic.data()) != kLcmLogSync) {
    fail(got < magic.size()
             ? fmt::format("{} bytes, too short to start with the LCM log sync word: not an LCM log", size_)
             : fmt::format("starts with 0x{:08x}, not the LCM log sync word 0x{:08x}: not an LCM log",
                           be32(magic.data()), kLcmLogSync));
  }
  rewind();
}

void LcmLogReader::fail(const std::string& what) const {
  throw LcmLogError(what.find("not an LCM log") != std::string::npos
                        ? path_ + ": " + what
                        : fmt::format("{} at byte {} of {}: {}", path_, offset_, size_, what),
                    offset_);
}

void LcmLogReader::read_exact(void* out, std::int64_t bytes) {
  if (bytes == 0) return;
  if (std::fread(out, 1, static_cast<std::size_t>(bytes), file_.get()) != static_cast<std::size_t>(bytes)) {
    const bool error = std::ferror(file_.get()) != 0;
    const int saved = errno;
    std::clearerr(file_.get());
    if (std::fseek(file_.get(), static_cast<long>(offset_), SEEK_SET) != 0) {
      throw LcmLogError(path_ + ": cannot seek back after a failed read", offset_);
    }
    fail(error ? std::string("read error: ") + std::strerror(saved) : std::string("the file ends inside the event"));
  }
}

std::optional<LcmLogEvent> LcmLogReader::next() {
  std::clearerr(file_.get());  // an end seen before: the file may have grown since
  std::int64_t left = size_ - offset_;
  if (left < kLcmLogHeaderBytes) {
    // A log still being written may have grown since it was opened.
    const std::int64_t now = file_size(file_.get());
    if (now > size_) size_ = now;
    left = size_ - offset_;
  }
  if (left == 0) return std::nullopt;
  if (left < kLcmLogHeaderBytes) {
    fail(fmt::format("truncated event header: {} of {} bytes", left, kLcmLogHeaderBytes));
  }
  std::array<std::uint8_t, kLcmLogHeaderBytes> header{};
  read_exact(header.data(), kLcmLogHeaderBytes);
  const std::uint32_t sync = be32(header.data());
  const auto seek_back = [this] { std::fseek(file_.get(), static_cast<long>(offset_), SEEK_SET); };
  if (sync != kLcmLogSync) {
    seek_back();
    fail(fmt::format("bad sync word 0x{:08x} (not 0x{:08x})", sync, kLcmLogSync));
  }
  LcmLogEvent event;
  event.offset = offset_;
  event.event_number = be64(header.data() + 4);
  event.utime = be64(header.data() + 12);
  const auto channel_bytes = static_cast<std::int32_t>(be32(header.data() + 20));
  const auto data_bytes = static_cast<std::int32_t>(be32(header.data() + 24));
  if (channel_bytes < 1 || channel_bytes > limits_.max_channel_bytes) {
    seek_back();
    fail(fmt::format("event {}: channel length {} is out of range [1, {}]", event.event_number, channel_bytes,
                     limits_.max_channel_bytes));
  }
  if (data_bytes < 0 || data_bytes > limits_.max_data_bytes) {
    seek_back();
    fail(fmt::format("event {} on a {}-byte channel: data length {} is out of range [0, {}]", event.event_number,
                     channel_bytes, data_bytes, limits_.max_data_bytes));
  }
  const std::int64_t body = std::int64_t{channel_bytes} + data_bytes;
  if (body > left - kLcmLogHeaderBytes) {
    const std::int64_t now = file_size(file_.get());
    if (now > size_) size_ = now;
    left = size_ - offset_;
    if (body > left - kLcmLogHeaderBytes) {
      seek_back();
      fail(fmt::format("event {} is truncated: it needs {} bytes, the file has {} left", event.event_number,
                       kLcmLogHeaderBytes + body, left));
    }
  }
  event.channel.resize(static_cast<std::size_t>(channel_bytes));
  read_exact(event.channel.data(), channel_bytes);
  event.data.resize(static_cast<std::size_t>(data_bytes));
  read_exact(event.data.data(), data_bytes);
  offset_ += kLcmLogHeaderBytes + body;
  ++events_;
  return event;
}

void LcmLogReader::rewind() {
  if (std::fseek(file_.get(), 0, SEEK_SET) != 0) {
    throw LcmLogError(path_ + ": cannot seek to the start: " + std::strerror(errno), 0);
  }
  offset_ = 0;
  events_ = 0;
}

}  // namespace mfot::service
