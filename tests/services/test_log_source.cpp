// Replay as a frame source: LcmLogSource reads a recorded log's MFOT_FRAME events as recorded,
// and SourceReader hands them (and any source's frames, encoded on its thread) to the publisher.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include "encoded_message.hpp"
#include "mfot/capture/lcmlog_source.hpp"
#include "mfot/capture/source_reader.hpp"
#include "mfot/poses_t.hpp"
#include "mfot/service/lcm_util.hpp"

namespace mfot::capture {
namespace {

namespace fs = std::filesystem;
using service::testing::Bytes;
using service::testing::encode;

frame_t small_frame(std::int64_t seq) {
  service::Frame frame;
  frame.capture_utime = 1000 + 33333 * seq;
  frame.width = 4;
  frame.height = 3;
  frame.fx = frame.fy = 500.f;
  frame.cx = 2.f;
  frame.cy = 1.5f;
  for (int i = 0; i < 12; ++i) {
    frame.depth_mm.push_back(static_cast<std::uint16_t>(800 + i + seq));
    frame.color.push_back(Rgb8{static_cast<std::uint8_t>(10 * i), 20, 30});
  }
  return service::encode_frame(
      frame, service::EncodeOptions{service::DepthEncoding::kRvl, service::ColorEncoding::kPng, 90, 1}, seq, "sim:test",
      5000 + seq);
}

class LogFile {
 public:
  LogFile()
      : path_(fs::temp_directory_path() / ("mfot_log_source_" + std::to_string(::getpid()) + "_" +
                                           testing::UnitTest::GetInstance()->current_test_info()->name())) {}
  ~LogFile() {
    std::error_code error;
    fs::remove(path_, error);
  }
  LogFile(const LogFile&) = delete;
  LogFile& operator=(const LogFile&) = delete;
  void write(const std::vector<std::pair<std::string, Bytes>>& events) {
    lcm::LogFile log(path_.string(), "w");
    ASSERT_TRUE(log.good());
    std::int64_t n = 0;
    for (const auto& [channel, bytes] : events) {
      lcm::LogEvent event{};
      event.eventnum = n;
      event.timestamp = 1000 * ++n;
      event.channel = channel;
      event.datalen = static_cast<std::int32_t>(bytes.size());
      event.data = const_cast<std::uint8_t*>(bytes.data());
      ASSERT_EQ(log.writeEvent(&event), 0);
    }
  }
  std::string str() const { return path_.string(); }

 private:
  fs::path path_;
};

TEST(LcmLogSource, GivesTheRecordedFramesAsRecordedAndSkipsTheRest) {
  LogFile file;
  const frame_t first = small_frame(0);
  const frame_t second = small_frame(1);
  Bytes truncated = encode(second);
  truncated.resize(truncated.size() - 5);
  poses_t poses{};
  file.write({{service::channel::kFrame, encode(first)},
              {service::channel::kPoses, encode(poses)},
              {service::channel::kFrame, truncated},
              {service::channel::kFrame, encode(second)}});
  LcmLogSource source(file.str());
  EXPECT_EQ(source.kind(), "lcmlog");
  auto item = source.next();
  ASSERT_TRUE(item && item->encoded);
  EXPECT_EQ(item->index, 0);
  EXPECT_EQ(item->frame.capture_utime, first.capture_utime);
  EXPECT_EQ(encode(*item->encoded), encode(first));  // byte for byte
  item = source.next();
  ASSERT_TRUE(item && item->encoded);
  EXPECT_EQ(item->index, 1);
  EXPECT_EQ(encode(*item->encoded), encode(second));
  EXPECT_EQ(source.undecodable(), 1);
  EXPECT_FALSE(source.next());
  ASSERT_TRUE(source.rewind());
  item = source.next();
  ASSERT_TRUE(item);
  EXPECT_EQ(item->index, 0);
}

TEST(LcmLogSource, RefusesAFileThatIsNotThere) {
  try {
    LcmLogSource source("/nonexistent/run/mfot.lcmlog");
    FAIL() << "opened a missing log";
  } catch (const CaptureError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/run/mfot.lcmlog"), std::string::npos) << e.what();
  }
}

TEST(LcmLogSource, ATruncatedLogFailsWithTheByteOffsetAfterItsFrames) {
  LogFile file;
  const Bytes first = encode(small_frame(0));
  file.write({{service::channel::kFrame, first}, {service::channel::kFrame, encode(small_frame(1))}});
  const auto whole = fs::file_size(file.str());
  fs::resize_file(file.str(), whole - 3);  // ends inside the second event
  LcmLogSource source(file.str());
  ASSERT_TRUE(source.next());
  try {
    source.next();
    FAIL() << "a truncated event read as the end of the log";
  } catch (const CaptureError& e) {
    const std::string offset = "at byte " + std::to_string(28 + 10 + first.size());
    EXPECT_NE(std::string(e.what()).find(offset), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("1 frames read before it"), std::string::npos) << e.what();
  }
}

TEST(LcmLogSource, RefusesAForeignFileAsNotAnLcmLog) {
  try {
    LcmLogSource source("/bin/ls");
    FAIL() << "opened /bin/ls as a log";
  } catch (const CaptureError& e) {
    EXPECT_NE(std::string(e.what()).find("/bin/ls: starts with 0x7f454c46"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("not an LCM log"), std::string::npos) << e.what();
  }
}

// Frames 0..count-1 as decoded images (the reader encodes them), or pre-encoded; throws at `fail_at`.
class ScriptedSource final : public FrameSource {
 public:
  ScriptedSource(int count, bool encoded, int fail_at = -1) : count_(count), encoded_(encoded), fail_at_(fail_at) {}
  std::optional<SourceFrame> next() override {
    if (index_ == fail_at_) throw CaptureError("scripted failure");
    if (index_ >= count_) return std::nullopt;
    SourceFrame item;
    item.index = index_;
    const frame_t message = small_frame(index_++);
    item.frame.capture_utime = message.capture_utime;
    if (encoded_) {
      item.encoded = message;
    } else {
      item.frame = service::decode_frame(message);
    }
    return item;
  }
  std::string name() const override { return "scripted"; }
  std::string kind() const override { return "test"; }
  bool rewind() override {
    index_ = 0;
    return true;
  }

 private:
  int count_;
  bool encoded_;
  int fail_at_;
  int index_ = 0;
};

SourceReader::Result next_result(SourceReader& reader) {
  auto result = reader.next(SourceReader::Clock::now() + std::chrono::seconds(10));
  if (!result) throw std::runtime_error("the reader gave nothing within 10 s");
  return std::move(*result);
}

TEST(SourceReader, PublishesEncodedFramesAsTheyAreAndEncodesTheOthers) {
  const service::EncodeOptions raw{service::DepthEncoding::kRaw, service::ColorEncoding::kRaw, 90, 1};
  SourceReader recorded(std::make_unique<ScriptedSource>(1, true), 0, false, raw);
  auto result = next_result(recorded);
  auto* frame = std::get_if<SourceReader::Frame>(&result);
  ASSERT_NE(frame, nullptr);
  EXPECT_EQ(encode(frame->message), encode(small_frame(0)));  // not re-encoded as raw
  EXPECT_FALSE(frame->item.encoded);
  EXPECT_TRUE(std::holds_alternative<SourceReader::Ended>(next_result(recorded)));

  SourceReader decoded(std::make_unique<ScriptedSource>(1, false), 0, false, raw);
  result = next_result(decoded);
  frame = std::get_if<SourceReader::Frame>(&result);
  ASSERT_NE(frame, nullptr);
  EXPECT_EQ(frame->message.depth_encoding, static_cast<std::int8_t>(service::DepthEncoding::kRaw));
  EXPECT_EQ(service::decode_frame(frame->message).depth_mm, service::decode_frame(small_frame(0)).depth_mm);
}

TEST(SourceReader, SeeksLoopsOnceAtEachEndAndReportsAFailure) {
  const service::EncodeOptions encoding{};
  SourceReader looping(std::make_unique<ScriptedSource>(3, true), 1, true, encoding);
  std::vector<std::int64_t> indices;
  std::vector<bool> rewound;
  for (int i = 0; i < 4; ++i) {
    auto result = next_result(looping);
    const auto* frame = std::get_if<SourceReader::Frame>(&result);
    ASSERT_NE(frame, nullptr);
    indices.push_back(frame->item.index);
    rewound.push_back(frame->rewound);
  }
  EXPECT_EQ(indices, (std::vector<std::int64_t>{1, 2, 1, 2}));
  EXPECT_EQ(rewound, (std::vector<bool>{false, false, true, false}));

  SourceReader failing(std::make_unique<ScriptedSource>(3, true, 1), 0, false, encoding);
  EXPECT_TRUE(std::holds_alternative<SourceReader::Frame>(next_result(failing)));
  const auto result = next_result(failing);
  const auto* failed = std::get_if<SourceReader::Failed>(&result);
  ASSERT_NE(failed, nullptr);
  EXPECT_EQ(failed->error, "scripted failure");
}

}  // namespace
}  // namespace mfot::capture
