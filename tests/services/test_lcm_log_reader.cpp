// LcmLogReader: every way a log file can be broken is reported with its byte offset, before anything
// is allocated from a header; a valid log (written by LCM's own writer) reads back event for event.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <vector>

#include "mfot/service/lcm_log_reader.hpp"

namespace mfot::service {
namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;

void put32(Bytes& out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<std::uint8_t>(v >> shift));
}
void put64(Bytes& out, std::uint64_t v) {
  put32(out, static_cast<std::uint32_t>(v >> 32));
  put32(out, static_cast<std::uint32_t>(v));
}

// One event as lcm-logger writes it; the lengths may be forged.
Bytes event_bytes(std::int64_t number, const std::string& channel, const Bytes& data, std::int64_t channel_len = -1,
                  std::int64_t data_len = -1, std::uint32_t sync = kLcmLogSync) {
  Bytes out;
  put32(out, sync);
  put64(out, static_cast<std::uint64_t>(number));
  put64(out, static_cast<std::uint64_t>(1000 + number));
  put32(out, static_cast<std::uint32_t>(channel_len < 0 ? static_cast<std::int64_t>(channel.size()) : channel_len));
  put32(out, static_cast<std::uint32_t>(data_len < 0 ? static_cast<std::int64_t>(data.size()) : data_len));
  out.insert(out.end(), channel.begin(), channel.end());
  out.insert(out.end(), data.begin(), data.end());
  return out;
}

class TempFile {
 public:
  TempFile()
      : path_(fs::temp_directory_path() / ("mfot_log_reader_" + std::to_string(::getpid()) + "_" +
                                           testing::UnitTest::GetInstance()->current_test_info()->name())) {}
  ~TempFile() {
    std::error_code error;
    fs::remove(path_, error);
  }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  void write(const Bytes& bytes) const {
    std::ofstream out(path_, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  }
  std::string str() const { return path_.string(); }

 private:
  fs::path path_;
};

Bytes concat(std::initializer_list<Bytes> parts) {
  Bytes out;
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

const Bytes kFirst = event_bytes(0, "MFOT_FRAME", Bytes(5, 7));   // 28 + 10 + 5 = 43 bytes
const Bytes kSecond = event_bytes(1, "MFOT_POSES", Bytes(3, 9));  // starts at byte 43

// The error `read` throws, after `events_before` good events; fails the test when none is thrown.
LcmLogError error_of(const std::string& path, int events_before) {
  try {
    LcmLogReader reader(path);
    for (int i = 0; i < events_before; ++i) {
      if (!reader.next()) throw std::runtime_error("the log ended before the broken event");
    }
    reader.next();
  } catch (const LcmLogError& e) {
    return e;
  }
  ADD_FAILURE() << path << " read without an error";
  return LcmLogError("", -1);
}

void expect_message(const LcmLogError& e, const std::vector<std::string>& parts) {
  for (const auto& part : parts) EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
}

TEST(LcmLogReader, ReadsWhatLcmsOwnWriterWroteWithOffsets) {
  TempFile file;
  {
    lcm::LogFile log(file.str(), "w");
    ASSERT_TRUE(log.good());
    std::vector<std::uint8_t> payload(70000, 3);
    for (int i = 0; i < 3; ++i) {
      lcm::LogEvent event{};
      event.eventnum = i;
      event.timestamp = 100 + i;
      event.channel = i == 1 ? "B" : "CHANNEL_A";
      event.datalen = i == 2 ? 0 : static_cast<std::int32_t>(payload.size());
      event.data = payload.data();
      ASSERT_EQ(log.writeEvent(&event), 0);
    }
  }
  LcmLogReader reader(file.str());
  std::vector<std::int64_t> offsets;
  std::vector<std::string> channels;
  while (auto event = reader.next()) {
    offsets.push_back(event->offset);
    channels.push_back(event->channel);
    EXPECT_EQ(event->utime, 100 + event->event_number);
    EXPECT_EQ(event->data, event->event_number == 2 ? Bytes{} : Bytes(70000, 3));
  }
  EXPECT_EQ(channels, (std::vector<std::string>{"CHANNEL_A", "B", "CHANNEL_A"}));
  EXPECT_EQ(offsets, (std::vector<std::int64_t>{0, 28 + 9 + 70000, 2 * 28 + 9 + 1 + 2 * 70000}));
  EXPECT_EQ(reader.offset(), reader.size());
  EXPECT_FALSE(reader.next());  // stays at the end
  reader.rewind();
  ASSERT_TRUE(reader.next());
  EXPECT_EQ(reader.events_read(), 1);
}

TEST(LcmLogReader, TruncatedMidHeader) {
  TempFile file;
  Bytes bytes = concat({kFirst, kSecond});
  bytes.resize(kFirst.size() + 20);
  file.write(bytes);
  const auto e = error_of(file.str(), 1);
  EXPECT_EQ(e.offset(), 43);
  expect_message(e, {file.str(), "at byte 43 of 63", "truncated event header: 20 of 28 bytes"});
}

TEST(LcmLogReader, TruncatedMidPayload) {
  TempFile file;
  Bytes bytes = concat({kFirst, kSecond});
  bytes.pop_back();
  file.write(bytes);
  const auto e = error_of(file.str(), 1);
  EXPECT_EQ(e.offset(), 43);
  expect_message(e, {"at byte 43", "event 1 is truncated: it needs 41 bytes, the file has 40 left"});
}

TEST(LcmLogReader, BadSyncWordAfterTheFirstEvent) {
  TempFile file;
  file.write(concat({kFirst, event_bytes(1, "X", {1}, -1, -1, 0xEDA1DA02u), kSecond}));
  const auto e = error_of(file.str(), 1);
  EXPECT_EQ(e.offset(), 43);
  expect_message(e, {"at byte 43", "bad sync word 0xeda1da02"});
}

TEST(LcmLogReader, HugeDataLengthIsRefusedBeforeAllocating) {
  TempFile file;
  file.write(concat({kFirst, event_bytes(1, "MFOT_FRAME", Bytes(16, 0), -1, 0x7fffffff)}));
  const auto e = error_of(file.str(), 1);
  EXPECT_EQ(e.offset(), 43);
  expect_message(e, {"data length 2147483647 is out of range [0, 268435456]"});

  // Within the sane maximum but beyond the file's end: truncated, not allocated.
  file.write(concat({kFirst, event_bytes(1, "MFOT_FRAME", Bytes(16, 0), -1, 200 * 1024 * 1024)}));
  expect_message(error_of(file.str(), 1), {"event 1 is truncated: it needs 209715238 bytes"});

  // Negative (a sign bit set).
  file.write(concat({kFirst, event_bytes(1, "MFOT_FRAME", Bytes(16, 0), -1, 0xfffffff0u)}));
  expect_message(error_of(file.str(), 1), {"data length -16 is out of range"});
}

TEST(LcmLogReader, HugeOrEmptyChannelLengthIsRefused) {
  TempFile file;
  file.write(concat({kFirst, event_bytes(1, "MFOT_FRAME", Bytes(16, 0), 0x7fffffff)}));
  auto e = error_of(file.str(), 1);
  EXPECT_EQ(e.offset(), 43);
  expect_message(e, {"channel length 2147483647 is out of range [1, 999]"});
  file.write(concat({kFirst, event_bytes(1, "", Bytes(16, 0))}));
  expect_message(error_of(file.str(), 1), {"channel length 0 is out of range"});
}

TEST(LcmLogReader, EmptyFileIsNotAnLcmLog) {
  TempFile file;
  file.write({});
  const auto e = error_of(file.str(), 0);
  EXPECT_EQ(e.offset(), 0);
  expect_message(e, {file.str(), "empty (0 bytes): not an LCM log"});
}

TEST(LcmLogReader, ForeignFileIsNotAnLcmLog) {
  TempFile file;
  file.write(
      Bytes{0x7f, 'E', 'L', 'F', 2, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 3, 0, 0x3e, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0});
  expect_message(error_of(file.str(), 0), {file.str(), "starts with 0x7f454c46", "not an LCM log"});
  file.write(Bytes{0xED, 0xA1});
  expect_message(error_of(file.str(), 0), {"2 bytes, too short", "not an LCM log"});
  expect_message(error_of(fs::temp_directory_path().string(), 0), {"not a regular file: not an LCM log"});
  expect_message(error_of("/nonexistent/dir/mfot.lcmlog", 0), {"/nonexistent/dir/mfot.lcmlog", "cannot open"});
}

TEST(LcmLogReader, ALogThatGrowsIsReadOnAsItGrows) {
  TempFile file;
  file.write(kFirst);
  LcmLogReader reader(file.str());
  ASSERT_TRUE(reader.next());
  EXPECT_FALSE(reader.next());
  file.write(concat({kFirst, kSecond}));  // lcm-logger appended an event
  const auto event = reader.next();
  ASSERT_TRUE(event);
  EXPECT_EQ(event->channel, "MFOT_POSES");
  EXPECT_EQ(event->offset, 43);
}

}  // namespace
}  // namespace mfot::service
