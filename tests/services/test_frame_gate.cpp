// FrameGate: the sizes and sequence checks preprocess makes before it queues a frame.
#include <gtest/gtest.h>

#include <cstdint>

#include "mfot/service/frame_codec.hpp"
#include "mfot/service/frame_gate.hpp"

namespace mfot::service {
namespace {

// A small raw frame (depth and colour uncompressed) with `seq`, sent by capture process `sender`.
frame_t raw_frame(std::int64_t seq, std::int64_t sender) {
  Frame frame;
  frame.width = 8;
  frame.height = 6;
  frame.fx = frame.fy = 525.f;
  frame.cx = 3.5f;
  frame.cy = 2.5f;
  frame.depth_mm.assign(48, 800);
  frame.color.assign(48, Rgb8{10, 20, 30});
  EncodeOptions options;
  options.depth = DepthEncoding::kRaw;
  options.color = ColorEncoding::kRaw;
  frame_t message = encode_frame(frame, options, seq, "test", 0);
  message.envelope.sender = sender;
  return message;
}

TEST(FrameGate, AdmitsAGrowingSequenceAndRefusesARepeatFromTheSameCapture) {
  FrameGate gate;
  EXPECT_FALSE(gate.admit(raw_frame(0, 7)));
  EXPECT_FALSE(gate.admit(raw_frame(1, 7)));
  EXPECT_FALSE(gate.admit(raw_frame(5, 7)));  // frames lost in between are fine
  const auto repeat = gate.admit(raw_frame(5, 7));
  ASSERT_TRUE(repeat);
  EXPECT_EQ(repeat->kind, "frame seq not increasing");
  EXPECT_NE(repeat->detail.find("seq 5 after 5"), std::string::npos) << repeat->detail;
  EXPECT_TRUE(gate.admit(raw_frame(3, 7)));
  EXPECT_FALSE(gate.admit(raw_frame(6, 7)));  // a refusal changed nothing
}

TEST(FrameGate, ARestartedCaptureMayStartAgainButNoSequenceIsNegative) {
  FrameGate gate;
  EXPECT_FALSE(gate.admit(raw_frame(40, 7)));
  EXPECT_FALSE(gate.admit(raw_frame(0, 8)));  // another process: a restarted capture
  EXPECT_TRUE(gate.admit(raw_frame(-1, 9)));
}

TEST(FrameGate, RefusesSizesThatDoNotFitTheImage) {
  FrameGate gate;
  frame_t huge = raw_frame(0, 7);
  huge.depth_data.resize(64u << 20);  // a forged 64 MB depth block for an 8 x 6 image
  huge.depth_size = static_cast<std::int32_t>(huge.depth_data.size());
  const auto refusal = gate.admit(huge);
  ASSERT_TRUE(refusal);
  EXPECT_EQ(refusal->kind, "invalid frame");
  EXPECT_FALSE(gate.admit(raw_frame(0, 7)));  // the refused frame did not count as seq 0
}

}  // namespace
}  // namespace mfot::service
