#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "mfot/service/depth_rvl.hpp"
#include "mfot/service/frame_codec.hpp"
#include "mfot/service/image_io.hpp"

namespace mfot::service {
namespace {

// A frame with smooth colour gradients (JPEG-friendly), a depth ramp with holes and the extreme
// values 0 and 65535.
Frame make_frame(int width = 64, int height = 48) {
  Frame frame;
  frame.capture_utime = 1234567;
  frame.width = width;
  frame.height = height;
  frame.fx = 525.0f;
  frame.fy = 526.0f;
  frame.cx = width / 2.0f - 0.5f;
  frame.cy = height / 2.0f - 0.5f;
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      std::uint16_t depth = static_cast<std::uint16_t>(600 + 7 * u + 3 * v);
      if ((u + v) % 17 == 0) depth = 0;
      frame.depth_mm.push_back(depth);
      frame.color.push_back(Rgb8{static_cast<std::uint8_t>(40 + 160 * u / width),
                                 static_cast<std::uint8_t>(30 + 200 * v / height),
                                 static_cast<std::uint8_t>(100 + 60 * (u + v) / (width + height))});
    }
  }
  frame.depth_mm[1] = 65535;
  return frame;
}

EncodeOptions options(DepthEncoding depth, ColorEncoding color) {
  EncodeOptions o;
  o.depth = depth;
  o.color = color;
  return o;
}

// Through the LCM wire format as well, so the round trip covers what subscribers see.
frame_t over_the_wire(const frame_t& message) {
  std::vector<std::uint8_t> buffer(static_cast<std::size_t>(message.getEncodedSize()));
  EXPECT_EQ(message.encode(buffer.data(), 0, static_cast<int>(buffer.size())), static_cast<int>(buffer.size()));
  frame_t decoded;
  EXPECT_EQ(decoded.decode(buffer.data(), 0, static_cast<int>(buffer.size())), static_cast<int>(buffer.size()));
  return decoded;
}

void expect_same_geometry(const Frame& a, const Frame& b) {
  EXPECT_EQ(a.capture_utime, b.capture_utime);
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  EXPECT_EQ(a.fx, b.fx);
  EXPECT_EQ(a.fy, b.fy);
  EXPECT_EQ(a.cx, b.cx);
  EXPECT_EQ(a.cy, b.cy);
}

template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const FrameCodecError& e) {
    return e.what();
  }
  return "<no FrameCodecError>";
}

TEST(FrameCodec, LosslessEncodingsRoundTripExactly) {
  const Frame frame = make_frame();
  for (const auto depth : {DepthEncoding::kRaw, DepthEncoding::kZlib, DepthEncoding::kRvl}) {
    for (const auto color : {ColorEncoding::kRaw, ColorEncoding::kPng}) {
      SCOPED_TRACE(to_string(depth) + "/" + to_string(color));
      const frame_t message = encode_frame(frame, options(depth, color), 42, "test:source", 99);
      EXPECT_EQ(message.seq, 42);
      EXPECT_EQ(message.source, "test:source");
      EXPECT_EQ(message.utime, 99);
      EXPECT_EQ(message.depth_encoding, static_cast<std::int8_t>(depth));
      EXPECT_EQ(message.color_encoding, static_cast<std::int8_t>(color));
      const Frame decoded = decode_frame(over_the_wire(message));
      expect_same_geometry(frame, decoded);
      EXPECT_EQ(decoded.depth_mm, frame.depth_mm);
      EXPECT_EQ(decoded.color, frame.color);
    }
  }
}

TEST(FrameCodec, DepthOnlyDecodingGivesTheSameDepthAndNoColour) {
  const Frame frame = make_frame();
  for (const auto color : {ColorEncoding::kRaw, ColorEncoding::kJpeg, ColorEncoding::kPng}) {
    SCOPED_TRACE(to_string(color));
    const frame_t message = over_the_wire(encode_frame(frame, options(DepthEncoding::kRvl, color), 5, "t", 0));
    const Frame depth_only = decode_frame(message, FrameParts::kDepthOnly);
    expect_same_geometry(frame, depth_only);
    EXPECT_EQ(depth_only.depth_mm, frame.depth_mm);
    EXPECT_TRUE(depth_only.color.empty());
  }
  // The colour's header fields are still checked.
  frame_t message = encode_frame(frame, options(DepthEncoding::kRvl, ColorEncoding::kJpeg), 6, "t", 0);
  message.color_size += 1;
  EXPECT_NE(error_of([&] { decode_frame(message, FrameParts::kDepthOnly); }).find("color_size"), std::string::npos);
  message.color_size -= 1;
  message.color_encoding = 7;
  EXPECT_NE(error_of([&] { decode_frame(message, FrameParts::kDepthOnly); }).find("unknown color_encoding 7"),
            std::string::npos);
}

TEST(FrameCodec, RawDepthIsLittleEndian) {
  Frame frame = make_frame(2, 1);
  frame.depth_mm = {0x1234, 0xabcd};
  const frame_t message = encode_frame(frame, EncodeOptions{}, 0, "t", 0);
  ASSERT_EQ(message.depth_data.size(), 4u);
  EXPECT_EQ(message.depth_data[0], 0x34);
  EXPECT_EQ(message.depth_data[1], 0x12);
  EXPECT_EQ(message.depth_data[2], 0xcd);
  EXPECT_EQ(message.depth_data[3], 0xab);
  EXPECT_EQ(message.color_data.size(), 6u);
}

TEST(FrameCodec, CompressionShrinksStructuredImages) {
  const Frame frame = make_frame(160, 120);
  const frame_t raw = encode_frame(frame, options(DepthEncoding::kRaw, ColorEncoding::kRaw), 0, "t", 0);
  const frame_t packed = encode_frame(frame, options(DepthEncoding::kZlib, ColorEncoding::kJpeg), 0, "t", 0);
  EXPECT_EQ(raw.depth_data.size(), 160u * 120u * 2u);
  EXPECT_EQ(raw.color_data.size(), 160u * 120u * 3u);
  EXPECT_LT(packed.depth_data.size(), raw.depth_data.size() / 2);
  EXPECT_LT(packed.color_data.size(), raw.color_data.size() / 4);
}

TEST(FrameCodec, JpegStaysWithinToleranceAndQualityTradesSize) {
  const Frame frame = make_frame(128, 96);
  EncodeOptions high = options(DepthEncoding::kRaw, ColorEncoding::kJpeg);
  high.jpeg_quality = 95;
  EncodeOptions low = high;
  low.jpeg_quality = 20;
  const frame_t high_message = encode_frame(frame, high, 0, "t", 0);
  const frame_t low_message = encode_frame(frame, low, 0, "t", 0);
  EXPECT_LT(low_message.color_data.size(), high_message.color_data.size());

  const Frame decoded = decode_frame(over_the_wire(high_message));
  expect_same_geometry(frame, decoded);
  EXPECT_EQ(decoded.depth_mm, frame.depth_mm);
  ASSERT_EQ(decoded.color.size(), frame.color.size());
  double total = 0.0;
  int worst = 0;
  for (std::size_t i = 0; i < frame.color.size(); ++i) {
    for (const auto& [a, b] :
         {std::pair{frame.color[i].r, decoded.color[i].r}, std::pair{frame.color[i].g, decoded.color[i].g},
          std::pair{frame.color[i].b, decoded.color[i].b}}) {
      const int d = std::abs(int{a} - int{b});
      total += d;
      worst = std::max(worst, d);
    }
  }
  EXPECT_LT(total / (3.0 * static_cast<double>(frame.color.size())), 2.0);
  EXPECT_LE(worst, 24);
}

TEST(FrameCodec, EncodeRejectsInconsistentFramesAndOptions) {
  Frame frame = make_frame();
  frame.color.pop_back();
  EXPECT_NE(error_of([&] { encode_frame(frame, EncodeOptions{}, 0, "t", 0); }).find("colour has"), std::string::npos);
  frame = make_frame();
  frame.depth_mm.push_back(1);
  EXPECT_NE(error_of([&] { encode_frame(frame, EncodeOptions{}, 0, "t", 0); }).find("depth has"), std::string::npos);
  frame = make_frame();
  frame.fx = 0.0f;
  EXPECT_NE(error_of([&] { encode_frame(frame, EncodeOptions{}, 0, "t", 0); }).find("focal"), std::string::npos);

  EncodeOptions bad;
  bad.jpeg_quality = 0;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
  bad = EncodeOptions{};
  bad.zlib_level = 10;
  try {
    bad.validate();
    ADD_FAILURE() << "zlib_level 10 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("zlib_level"), std::string::npos);
  }
}

TEST(FrameCodec, ParsesEncodingNames) {
  EXPECT_EQ(parse_depth_encoding("zlib"), DepthEncoding::kZlib);
  EXPECT_EQ(parse_depth_encoding("rvl"), DepthEncoding::kRvl);
  EXPECT_EQ(parse_depth_encoding("raw"), DepthEncoding::kRaw);
  EXPECT_EQ(parse_color_encoding("jpeg"), ColorEncoding::kJpeg);
  EXPECT_EQ(parse_color_encoding("png"), ColorEncoding::kPng);
  EXPECT_EQ(parse_color_encoding("raw"), ColorEncoding::kRaw);
  EXPECT_THROW(parse_depth_encoding("png"), std::invalid_argument);
  EXPECT_THROW(parse_color_encoding("JPEG"), std::invalid_argument);
}

TEST(FrameCodec, RejectsBadHeaderFields) {
  const frame_t good = encode_frame(make_frame(), EncodeOptions{}, 7, "t", 0);
  frame_t m = good;
  m.width = 0;
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("invalid size 0x48"), std::string::npos);
  m = good;
  m.height = -3;
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("invalid size"), std::string::npos);
  m = good;
  m.fy = std::nanf("");
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("focal"), std::string::npos);
  m = good;
  m.cx = INFINITY;
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("principal point"), std::string::npos);
  m = good;
  m.depth_size += 1;
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("depth_size"), std::string::npos);
  m = good;
  m.color_size = -1;
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("color_size"), std::string::npos);
  m = good;
  m.depth_encoding = 5;
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("unknown depth_encoding 5"), std::string::npos);
  m = good;
  m.color_encoding = 3;
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("unknown color_encoding 3"), std::string::npos);
  // The message names the frame it came from.
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("seq 7"), std::string::npos);
}

TEST(FrameCodec, RejectsWrongSizedRawData) {
  frame_t m = encode_frame(make_frame(), EncodeOptions{}, 0, "t", 0);
  m.width = 32;  // the data still holds 64x48 pixels
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("raw depth has 6144 bytes, expected 3072"), std::string::npos);
  m = encode_frame(make_frame(), EncodeOptions{}, 0, "t", 0);
  m.color_data.pop_back();
  m.color_size -= 1;
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("raw colour has"), std::string::npos);
}

TEST(FrameCodec, RejectsTruncatedOrCorruptZlib) {
  const frame_t good = encode_frame(make_frame(), options(DepthEncoding::kZlib, ColorEncoding::kRaw), 0, "t", 0);
  frame_t m = good;
  m.depth_data.resize(m.depth_data.size() - 5);
  m.depth_size = static_cast<std::int32_t>(m.depth_data.size());
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("truncated or corrupt"), std::string::npos);

  m = good;
  m.depth_data[m.depth_data.size() / 2] ^= 0x5a;
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("depth:"), std::string::npos);

  m = good;
  m.depth_data.push_back(0);
  m.depth_size += 1;
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("trailing"), std::string::npos);

  m = good;
  m.height = 24;  // the stream inflates to twice the bytes this size allows
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("more than the expected"), std::string::npos);

  m = good;
  m.height = 96;  // the stream inflates to half the bytes this size needs
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("depth:"), std::string::npos);

  m = good;
  m.depth_data.clear();
  m.depth_size = 0;
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("depth:"), std::string::npos);
}

TEST(FrameCodec, RejectsTruncatedOrMismatchedJpeg) {
  const Frame frame = make_frame();
  const frame_t good = encode_frame(frame, options(DepthEncoding::kRaw, ColorEncoding::kJpeg), 0, "t", 0);
  frame_t m = good;
  m.color_data.resize(m.color_data.size() / 2);
  m.color_size = static_cast<std::int32_t>(m.color_data.size());
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("JPEG data is corrupt or truncated"), std::string::npos);

  m = good;
  m.color_data.clear();
  m.color_size = 0;
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("JPEG data is empty"), std::string::npos);

  m = good;
  m.color_data.assign(m.color_data.size(), 0x42);
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("colour:"), std::string::npos);

  const frame_t small = encode_frame(make_frame(32, 24), options(DepthEncoding::kRaw, ColorEncoding::kJpeg), 0, "t", 0);
  m = good;
  m.color_data = small.color_data;
  m.color_size = small.color_size;
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("JPEG is 32x24, expected 64x48"), std::string::npos);
}

TEST(FrameCodec, RejectsCorruptOrMismatchedPng) {
  const frame_t good = encode_frame(make_frame(), options(DepthEncoding::kRaw, ColorEncoding::kPng), 0, "t", 0);
  frame_t m = good;
  m.color_data.resize(m.color_data.size() - 20);
  m.color_size = static_cast<std::int32_t>(m.color_data.size());
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("colour:"), std::string::npos);

  m = good;
  m.color_data[m.color_data.size() / 2] ^= 0xff;  // inside IDAT: the chunk CRC no longer matches
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("colour:"), std::string::npos);

  m = good;
  m.color_data[1] = 'X';
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("not PNG data"), std::string::npos);

  const frame_t small = encode_frame(make_frame(32, 24), options(DepthEncoding::kRaw, ColorEncoding::kPng), 0, "t", 0);
  m = good;
  m.color_data = small.color_data;
  m.color_size = small.color_size;
  EXPECT_NE(error_of([&] { decode_frame(m); }).find("PNG is 32x24, expected 64x48"), std::string::npos);
}

// Random damage must end in either a valid frame of the declared size or a FrameCodecError.
TEST(FrameCodec, RandomCorruptionNeverYieldsMisSizedFrames) {
  std::mt19937_64 generator(20240601);
  const Frame frame = make_frame(40, 30);
  int rejected = 0;
  for (const auto& o :
       {options(DepthEncoding::kZlib, ColorEncoding::kJpeg), options(DepthEncoding::kZlib, ColorEncoding::kPng)}) {
    const frame_t good = encode_frame(frame, o, 0, "t", 0);
    for (int trial = 0; trial < 150; ++trial) {
      frame_t m = good;
      auto& target = trial % 2 == 0 ? m.depth_data : m.color_data;
      const int flips = 1 + static_cast<int>(generator() % 4);
      for (int f = 0; f < flips; ++f)
        target[generator() % target.size()] ^= static_cast<std::uint8_t>(1 + generator() % 255);
      if (trial % 3 == 0) target.resize(generator() % target.size());
      m.depth_size = static_cast<std::int32_t>(m.depth_data.size());
      m.color_size = static_cast<std::int32_t>(m.color_data.size());
      try {
        const Frame decoded = decode_frame(m);
        EXPECT_EQ(decoded.depth_mm.size(), 40u * 30u);
        EXPECT_EQ(decoded.color.size(), 40u * 30u);
      } catch (const FrameCodecError&) {
        ++rejected;
      }
    }
  }
  // zlib and PNG carry checksums, so most damage must be detected.
  EXPECT_GT(rejected, 150);
}

// Depth with the structure RVL relies on and the cases it must survive: missing runs at both
// ends, single pixels, the largest jumps (1 <-> 65535) and long smooth stretches.
TEST(DepthRvl, RoundTripsEveryValuePatternExactly) {
  std::mt19937 rng(7);
  std::vector<std::uint16_t> depth(20011);
  std::uniform_int_distribution<int> step(-6, 6), kind(0, 99);
  int value = 900;
  for (auto& d : depth) {
    const int k = kind(rng);
    value = std::clamp(value + step(rng), 1, 65535);
    d = k < 15 ? 0 : k < 17 ? 65535 : k < 19 ? 1 : static_cast<std::uint16_t>(value);
  }
  for (std::size_t i = 5000; i < 6000; ++i) depth[i] = 0;
  depth.front() = 0;
  depth.back() = 0;
  const auto packed = encode_depth_rvl(depth);
  EXPECT_EQ(decode_depth_rvl(packed.data(), packed.size(), depth.size()), depth);
  for (const std::vector<std::uint16_t>& small :
       std::vector<std::vector<std::uint16_t>>{{}, {0}, {1}, {65535}, {0, 0, 0}, {5, 5, 5}, {65535, 1, 65535, 0, 1}}) {
    const auto bytes = encode_depth_rvl(small);
    EXPECT_EQ(decode_depth_rvl(bytes.data(), bytes.size(), small.size()), small);
  }
}

// A tilted table (1 mm every 4 pixels) with a missing patch: one nibble per measured pixel.
TEST(DepthRvl, CompressesSmoothDepthWithHolesToAThird) {
  std::vector<std::uint16_t> depth;
  for (int v = 0; v < 120; ++v) {
    for (int u = 0; u < 160; ++u) {
      const bool hole = u > 40 && u < 70 && v > 30 && v < 50;
      depth.push_back(hole ? 0 : static_cast<std::uint16_t>(900 + u / 4 + v / 4));
    }
  }
  const auto packed = encode_depth_rvl(depth);
  EXPECT_LT(packed.size(), depth.size() * 2 / 3);
  EXPECT_EQ(decode_depth_rvl(packed.data(), packed.size(), depth.size()), depth);
}

TEST(DepthRvl, RejectsTruncatedOverlongAndOutOfRangeStreams) {
  const std::vector<std::uint16_t> depth = {0, 0, 700, 701, 702, 0, 650};
  const auto packed = encode_depth_rvl(depth);
  const auto decode = [](const std::vector<std::uint8_t>& bytes, std::size_t pixels) {
    return error_of([&] { decode_depth_rvl(bytes.data(), bytes.size(), pixels); });
  };
  EXPECT_NE(decode({packed.begin(), packed.end() - 1}, depth.size()).find("truncated"), std::string::npos);
  EXPECT_NE(decode(packed, depth.size() - 1).find("passes the image"), std::string::npos);
  EXPECT_NE(decode(packed, depth.size() + 3).find("truncated"), std::string::npos);
  std::vector<std::uint8_t> trailing = packed;
  trailing.push_back(0x11);
  EXPECT_NE(decode(trailing, depth.size()).find("trailing"), std::string::npos);
  // zeros 0, nonzeros 1, zigzag 1 (delta -1 from 0): value 0 is not a measurement.
  EXPECT_NE(decode({0x01, 0x10}, 1).find("outside [1, 65535]"), std::string::npos);
  EXPECT_NE(decode({0x00, 0x00}, 4).find("empty run"), std::string::npos);
  EXPECT_NE(decode(std::vector<std::uint8_t>(8, 0xff), 4).find("more than 11 groups"), std::string::npos);
  frame_t message = encode_frame(make_frame(8, 6), options(DepthEncoding::kRvl, ColorEncoding::kRaw), 3, "t", 0);
  message.depth_data.pop_back();
  message.depth_size = static_cast<std::int32_t>(message.depth_data.size());
  EXPECT_NE(error_of([&] { decode_frame(message); }).find("frame_t seq 3: depth: RVL depth"), std::string::npos);
}

TEST(ImageIo, Png16AndRgbRoundTripInMemory) {
  Image16 depth{3, 2, {0, 1, 65535, 256, 4660, 9}};
  EXPECT_EQ(decode_png16(encode_png16(depth).data(), encode_png16(depth).size()).pixels, depth.pixels);
  ImageRgb color{2, 2, {{1, 2, 3}, {250, 251, 252}, {0, 0, 0}, {9, 8, 7}}};
  const auto bytes = encode_png_rgb(color);
  const ImageRgb back = decode_png_rgb(bytes.data(), bytes.size());
  EXPECT_EQ(back.width, 2);
  EXPECT_EQ(back.height, 2);
  EXPECT_EQ(back.pixels, color.pixels);
}

TEST(ImageIo, FastAndSmallPngFilesHoldTheSamePixels) {
  // A label image: runs of a few values, as the merger writes every frame.
  Image16 labels{64, 48, std::vector<std::uint16_t>(64 * 48, 65535)};
  for (int i = 0; i < 64 * 20; ++i)
    labels.pixels[static_cast<std::size_t>(700 + i)] = static_cast<std::uint16_t>(i % 3);
  const std::string path = ::testing::TempDir() + "/mfot_png_compression_test.png";
  for (const auto compression : {PngCompression::kSmall, PngCompression::kFast}) {
    write_png16(path, labels, compression);
    const Image16 back = read_png16(path);
    EXPECT_EQ(back.width, labels.width);
    EXPECT_EQ(back.height, labels.height);
    EXPECT_EQ(back.pixels, labels.pixels);
  }
  std::remove(path.c_str());
}

TEST(ImageIo, RejectsWrongPngKindAndBadSizes) {
  ImageRgb color{2, 1, {{1, 2, 3}, {4, 5, 6}}};
  const auto bytes = encode_png_rgb(color);
  try {
    decode_png16(bytes.data(), bytes.size());
    ADD_FAILURE() << "RGB PNG accepted as 16-bit";
  } catch (const ImageIoError& e) {
    EXPECT_NE(std::string(e.what()).find("expected a 16-bit greyscale PNG, got 8-bit RGB"), std::string::npos);
  }
  EXPECT_THROW(encode_png16(Image16{2, 2, {1, 2, 3}}), ImageIoError);
  EXPECT_THROW(encode_png_rgb(ImageRgb{0, 0, {}}), ImageIoError);
  EXPECT_THROW(decode_png_rgb(bytes.data(), 10), ImageIoError);
  EXPECT_THROW(decode_png_rgb(nullptr, 0), ImageIoError);
}

}  // namespace
}  // namespace mfot::service
