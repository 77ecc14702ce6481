#pragma once
// In-memory RGB-D frames and their wire form mfot::frame_t (lcmtypes/frame_t.lcm).
// Depth travels raw or zlib-compressed (both lossless); colour raw, PNG (lossless) or JPEG
// (lossy, quality configurable). Decoding validates every field against width*height and the
// encodings, so a truncated or corrupt message becomes a FrameCodecError, never bad pixels.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "mfot/frame_t.hpp"
#include "mfot/thread_pool.hpp"
#include "mfot/types.hpp"

namespace mfot::service {

struct FrameCodecError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// One registered RGB-D frame: depth aligned to colour, pinhole intrinsics of the colour camera.
struct Frame {
  std::int64_t capture_utime = 0;  // sensor or recording timestamp, microseconds
  int width = 0;
  int height = 0;
  float fx = 0.0f, fy = 0.0f, cx = 0.0f, cy = 0.0f;  // pixels
  std::vector<std::uint16_t> depth_mm;               // width*height, row-major, millimetres, 0 = no measurement
  std::vector<Rgb8> color;                           // width*height, row-major

  // Throws FrameCodecError when sizes or intrinsics are inconsistent.
  void validate() const;
};

enum class DepthEncoding : std::int8_t {
  kRaw = frame_t::DEPTH_RAW,
  kZlib = frame_t::DEPTH_ZLIB,
  kRvl = frame_t::DEPTH_RVL
};
enum class ColorEncoding : std::int8_t {
  kRaw = frame_t::COLOR_RAW,
  kJpeg = frame_t::COLOR_JPEG,
  kPng = frame_t::COLOR_PNG
};

// "raw" | "zlib" | "rvl" and "raw" | "jpeg" | "png"; anything else throws std::invalid_argument.
DepthEncoding parse_depth_encoding(const std::string& name);
ColorEncoding parse_color_encoding(const std::string& name);
std::string to_string(DepthEncoding encoding);
std::string to_string(ColorEncoding encoding);

struct EncodeOptions {
  DepthEncoding depth = DepthEncoding::kRaw;
  ColorEncoding color = ColorEncoding::kRaw;
  int jpeg_quality = 90;  // 1..100
  int zlib_level = 1;     // 0..9 for depth zlib and PNG colour; 1 keeps encoding fast at 30 Hz

  // Throws std::invalid_argument naming the field and its allowed range.
  void validate() const;
};

// Largest accepted frame side in pixels.
inline constexpr int kMaxFrameSide = 8192;

// Builds the wire message. `utime` is the publish time, `seq` the sequence number.
frame_t encode_frame(const Frame& frame, const EncodeOptions& options, std::int64_t seq, const std::string& source,
                     std::int64_t utime);

// Which images decode_frame decodes. kDepthOnly leaves Frame::color empty, for consumers that
// need depth alone (the merger's label images): the JPEG colour is most of a frame's decoding time.
enum class FrameParts { kDepthAndColor, kDepthOnly };

// A received frame's sizes checked before it is queued or decoded (issue 55): sides in
// 1..kMaxFrameSide, and depth_size / color_size at most twice their raw size plus 64 KiB (every
// encoding compresses, so a 60 MB frame of 640x480 is refused at once). nullopt = plausible, else why not.
std::optional<std::string> implausible_frame_sizes(const frame_t& message);

// Validates and decodes a wire message; throws FrameCodecError naming the problem. The colour's
// size and encoding fields are checked in both modes. With a pool of two or more threads depth
// and colour decode side by side (the same result; a depth error is reported before a colour one).
Frame decode_frame(const frame_t& message, FrameParts parts = FrameParts::kDepthAndColor, ThreadPool* pool = nullptr);

// The codec pieces, exposed for tools and tests.
std::vector<std::uint8_t> depth_to_bytes(const std::vector<std::uint16_t>& depth_mm);  // little-endian
std::vector<std::uint8_t> compress_zlib(const std::vector<std::uint8_t>& bytes, int level);
// Inflates exactly `expected_size` bytes; a short, long, corrupt or trailing-garbage stream throws.
std::vector<std::uint8_t> decompress_zlib(const std::uint8_t* data, std::size_t size, std::size_t expected_size);
std::vector<std::uint8_t> encode_jpeg(const std::vector<Rgb8>& color, int width, int height, int quality);
// Decodes a baseline or progressive JPEG that must be exactly width x height; libjpeg warnings
// (premature end of data, corrupt segments) are treated as errors.
std::vector<Rgb8> decode_jpeg(const std::uint8_t* data, std::size_t size, int width, int height);

}  // namespace mfot::service
