// DecodeAhead: the frame decoded on its own thread is decode_frame's; a decoding error reaches the
// caller at take(); misuse (two starts, a take without a start) is refused; a started frame that is
// never taken does not hold up destruction. PreprocessQueue: the same frames in the same order with
// and without decode-ahead, also when the oldest is dropped or undecodable.
#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

#include "mfot/service/decode_ahead.hpp"
#include "mfot/service/preprocess_queue.hpp"

namespace mfot::service {
namespace {

frame_t encoded_frame(std::int64_t seq) {
  Frame f;
  f.width = 64;
  f.height = 48;
  f.fx = f.fy = 60.f;
  f.cx = 32.f;
  f.cy = 24.f;
  for (int i = 0; i < f.width * f.height; ++i) {
    f.depth_mm.push_back(static_cast<std::uint16_t>(i % 7 == 0 ? 0 : 600 + (i * 13 + seq) % 400));
    f.color.push_back(Rgb8{static_cast<std::uint8_t>(i), static_cast<std::uint8_t>(i / 3), 90});
  }
  EncodeOptions options;
  options.depth = DepthEncoding::kRvl;
  options.color = ColorEncoding::kJpeg;
  return encode_frame(f, options, seq, "test", 0);
}

TEST(DecodeAhead, GivesTheFrameThatDecodeFrameGives) {
  DecodeAhead ahead;
  for (std::int64_t seq = 0; seq < 4; ++seq) {
    const frame_t message = encoded_frame(seq);
    ahead.start(message);
    EXPECT_EQ(ahead.started_seq(), seq);
    const Frame expected = decode_frame(message);
    const Frame got = ahead.take();
    EXPECT_FALSE(ahead.started_seq().has_value());
    EXPECT_EQ(got.depth_mm, expected.depth_mm);
    ASSERT_EQ(got.color.size(), expected.color.size());
    for (std::size_t i = 0; i < got.color.size(); ++i) {
      ASSERT_EQ(got.color[i].r, expected.color[i].r);
      ASSERT_EQ(got.color[i].g, expected.color[i].g);
      ASSERT_EQ(got.color[i].b, expected.color[i].b);
    }
    EXPECT_EQ(got.width, 64);
  }
}

TEST(DecodeAhead, ADecodingErrorReachesTake) {
  DecodeAhead ahead;
  frame_t broken = encoded_frame(1);
  broken.depth_data.resize(broken.depth_data.size() / 2);  // a cut RVL stream
  broken.depth_size = static_cast<std::int32_t>(broken.depth_data.size());
  ahead.start(broken);
  EXPECT_THROW(ahead.take(), FrameCodecError);
  const frame_t fine = encoded_frame(2);  // and it keeps working
  ahead.start(fine);
  EXPECT_EQ(ahead.take().depth_mm, decode_frame(fine).depth_mm);
}

TEST(DecodeAhead, RefusesMisuseAndStopsWithAFrameNotTaken) {
  const frame_t message = encoded_frame(3);
  {
    DecodeAhead ahead;
    EXPECT_THROW(ahead.take(), std::logic_error);
    ahead.start(message);
    EXPECT_THROW(ahead.start(message), std::logic_error);
  }  // destroyed with the frame started and not taken
}

frame_t cut_frame(std::int64_t seq) {
  frame_t broken = encoded_frame(seq);
  broken.depth_data.resize(broken.depth_data.size() / 2);
  broken.depth_size = static_cast<std::int32_t>(broken.depth_data.size());
  return broken;
}

// Pushes frames 0..9 (4 and 7 undecodable) into a queue of capacity 2, three at a time, and takes
// what it gives: the seq of each frame decoded (-seq - 1 for an undecodable one), checking each
// frame against decode_frame of its message.
std::vector<std::int64_t> drain(bool ahead) {
  PreprocessQueue queue(2, ahead ? 2 : 1);
  std::vector<std::int64_t> got;
  const auto take_one = [&] {
    const frame_t& message = queue.front();
    try {
      const Frame frame = queue.decode_front();
      EXPECT_EQ(frame.depth_mm, decode_frame(message).depth_mm) << "frame " << message.seq;
      got.push_back(message.seq);
    } catch (const FrameCodecError&) {
      got.push_back(-message.seq - 1);
    }
    EXPECT_THROW(queue.push_incoming(), std::logic_error);  // the oldest is in use
    queue.pop_front();
  };
  for (std::int64_t seq = 0; seq < 8;) {
    for (int k = 0; k < 3 && seq < 8; ++k, ++seq) {  // three arrive: with capacity 2 the oldest goes
      queue.incoming() = seq == 4 || seq == 7 ? cut_frame(seq) : encoded_frame(seq);
      queue.push_incoming();
    }
    take_one();  // one is left queued behind the next arrivals
  }
  while (!queue.empty()) take_one();
  for (std::int64_t seq = 8; seq < 10; ++seq) {  // two queued: the second is decoded ahead and used
    queue.incoming() = encoded_frame(seq);
    queue.push_incoming();
  }
  while (!queue.empty()) take_one();
  return got;
}

TEST(PreprocessQueue, GivesTheSameFramesWithAndWithoutDecodeAhead) {
  const std::vector<std::int64_t> plain = drain(false);
  EXPECT_EQ(drain(true), plain);
  // Capacity 2: the oldest of three arrivals is dropped; frames 4 and 7 are reported undecodable.
  EXPECT_EQ(plain, (std::vector<std::int64_t>{1, -5, 6, -8, 8, 9}));
}

TEST(PreprocessQueue, IsDestroyedSafelyWhileTheNextFrameIsDecodedAhead) {
  // As when preprocessing throws between decode_front and pop_front: the queued message being decoded
  // ahead must outlive that decoding (the decoder is destroyed, and joined, before the queue's frames).
  for (int round = 0; round < 20; ++round) {
    PreprocessQueue queue(4, 2);
    for (std::int64_t seq = 0; seq < 3; ++seq) {
      queue.incoming() = encoded_frame(seq);
      queue.push_incoming();
    }
    EXPECT_EQ(queue.decode_front().depth_mm, decode_frame(queue.front()).depth_mm);
  }
}

}  // namespace
}  // namespace mfot::service
