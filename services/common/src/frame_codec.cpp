#include "mfot/service/frame_codec.hpp"

#include "mfot/service/depth_rvl.hpp"
#include "mfot/service/image_io.hpp"

// jpeglib.h needs size_t and FILE declared first.
#include <jpeglib.h>
#include <zlib.h>

#include <cmath>
#include <csetjmp>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>

namespace mfot::service {
namespace {

std::size_t pixel_count(int width, int height) {
  return static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
}

void check_frame_size(const std::string& what, int width, int height) {
  if (width <= 0 || height <= 0 || width > kMaxFrameSide || height > kMaxFrameSide) {
    throw FrameCodecError(what + ": invalid size " + std::to_string(width) + "x" + std::to_string(height) +
                          " (each side must be 1.." + std::to_string(kMaxFrameSide) + ")");
  }
}

}  // namespace

std::optional<std::string> implausible_frame_sizes(const frame_t& message) {
  if (message.width <= 0 || message.height <= 0 || message.width > kMaxFrameSide || message.height > kMaxFrameSide) {
    return "size " + std::to_string(message.width) + "x" + std::to_string(message.height) + " (each side 1.." +
           std::to_string(kMaxFrameSide) + ")";
  }
  constexpr std::size_t kSlack = 64 * 1024;
  const std::size_t pixels = pixel_count(message.width, message.height);
  if (static_cast<std::size_t>(message.depth_size) > 2 * 2 * pixels + kSlack) {
    return "depth_size " + std::to_string(message.depth_size) + " bytes for " + std::to_string(message.width) + "x" +
           std::to_string(message.height) + " (at most twice the raw size plus 64 KiB)";
  }
  if (static_cast<std::size_t>(message.color_size) > 2 * 3 * pixels + kSlack) {
    return "color_size " + std::to_string(message.color_size) + " bytes for " + std::to_string(message.width) + "x" +
           std::to_string(message.height) + " (at most twice the raw size plus 64 KiB)";
  }
  return std::nullopt;
}

namespace {

void check_intrinsics(const std::string& what, float fx, float fy, float cx, float cy) {
  if (!(std::isfinite(fx) && fx > 0.0f && std::isfinite(fy) && fy > 0.0f)) {
    throw FrameCodecError(what + ": focal lengths must be finite and positive (fx=" + std::to_string(fx) +
                          ", fy=" + std::to_string(fy) + ")");
  }
  if (!(std::isfinite(cx) && std::isfinite(cy))) {
    throw FrameCodecError(what + ": principal point must be finite");
  }
}

// ---- JPEG ------------------------------------------------------------------------------------
// libjpeg's error_exit must not return; it long-jumps back into jpeg_compress_rgb /
// jpeg_decompress_rgb, which own no C++ objects (their state lives in the caller).
struct JpegErrorManager {
  jpeg_error_mgr base;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
};

extern "C" void on_jpeg_error(j_common_ptr info) {
  auto* manager = reinterpret_cast<JpegErrorManager*>(info->err);
  (*info->err->format_message)(info, manager->message);
  std::longjmp(manager->jump, 1);
}

// Level -1 is a warning about corrupt data (e.g. premature end of data): libjpeg would carry on
// with made-up pixels, so it is an error here. Trace messages (level >= 0) are ignored.
extern "C" void on_jpeg_message(j_common_ptr info, int level) {
  if (level < 0) on_jpeg_error(info);
}

struct JpegCompressState {
  jpeg_compress_struct info;
  JpegErrorManager error;
  unsigned char* buffer = nullptr;
  unsigned long size = 0;
};

bool jpeg_compress_rgb(JpegCompressState& state, const Rgb8* pixels, int width, int height, int quality) {
  state.info.err = jpeg_std_error(&state.error.base);
  state.error.base.error_exit = on_jpeg_error;
  state.error.base.emit_message = on_jpeg_message;
  if (setjmp(state.error.jump)) {
    jpeg_destroy_compress(&state.info);
    return false;
  }
  jpeg_create_compress(&state.info);
  jpeg_mem_dest(&state.info, &state.buffer, &state.size);
  state.info.image_width = static_cast<JDIMENSION>(width);
  state.info.image_height = static_cast<JDIMENSION>(height);
  state.info.input_components = 3;
  state.info.in_color_space = JCS_RGB;
  jpeg_set_defaults(&state.info);
  jpeg_set_quality(&state.info, quality, TRUE);
  jpeg_start_compress(&state.info, TRUE);
  while (state.info.next_scanline < state.info.image_height) {
    // libjpeg only reads the input rows.
    JSAMPROW row = const_cast<JSAMPROW>(
        reinterpret_cast<const JSAMPLE*>(pixels + static_cast<std::size_t>(state.info.next_scanline) * width));
    jpeg_write_scanlines(&state.info, &row, 1);
  }
  jpeg_finish_compress(&state.info);
  jpeg_destroy_compress(&state.info);
  return true;
}

struct JpegDecompressState {
  jpeg_decompress_struct info;
  JpegErrorManager error;
};

bool jpeg_decompress_rgb(JpegDecompressState& state, const std::uint8_t* data, std::size_t size, int width, int height,
                         Rgb8* out) {
  state.info.err = jpeg_std_error(&state.error.base);
  state.error.base.error_exit = on_jpeg_error;
  state.error.base.emit_message = on_jpeg_message;
  if (setjmp(state.error.jump)) {
    jpeg_destroy_decompress(&state.info);
    return false;
  }
  jpeg_create_decompress(&state.info);
  jpeg_mem_src(&state.info, data, static_cast<unsigned long>(size));
  jpeg_read_header(&state.info, TRUE);
  if (state.info.image_width != static_cast<JDIMENSION>(width) ||
      state.info.image_height != static_cast<JDIMENSION>(height)) {
    std::snprintf(state.error.message, sizeof state.error.message, "JPEG is %ux%u, expected %dx%d",
                  static_cast<unsigned>(state.info.image_width), static_cast<unsigned>(state.info.image_height), width,
                  height);
    jpeg_destroy_decompress(&state.info);
    return false;
  }
  state.info.out_color_space = JCS_RGB;
  jpeg_start_decompress(&state.info);
  if (state.info.output_components != 3) {
    std::snprintf(state.error.message, sizeof state.error.message, "JPEG decodes to %d components, expected 3",
                  state.info.output_components);
    jpeg_destroy_decompress(&state.info);
    return false;
  }
  while (state.info.output_scanline < state.info.output_height) {
    JSAMPROW row = reinterpret_cast<JSAMPLE*>(out + static_cast<std::size_t>(state.info.output_scanline) * width);
    jpeg_read_scanlines(&state.info, &row, 1);
  }
  jpeg_finish_decompress(&state.info);
  jpeg_destroy_decompress(&state.info);
  return true;
}

// Width and height from a PNG's IHDR, read before decoding so that a corrupt header cannot make
// the decoder allocate an image of the wrong size.
bool png_header_size(const std::uint8_t* data, std::size_t size, std::uint32_t& width, std::uint32_t& height) {
  static constexpr std::uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (size < 24 || std::memcmp(data, kSignature, 8) != 0 || std::memcmp(data + 12, "IHDR", 4) != 0) {
    return false;
  }
  const auto be32 = [&](std::size_t at) {
    return (std::uint32_t{data[at]} << 24) | (std::uint32_t{data[at + 1]} << 16) | (std::uint32_t{data[at + 2]} << 8) |
           std::uint32_t{data[at + 3]};
  };
  width = be32(16);
  height = be32(20);
  return true;
}

}  // namespace

void Frame::validate() const {
  check_frame_size("frame", width, height);
  check_intrinsics("frame", fx, fy, cx, cy);
  const std::size_t n = pixel_count(width, height);
  if (depth_mm.size() != n) {
    throw FrameCodecError("frame: depth has " + std::to_string(depth_mm.size()) + " pixels, expected " +
                          std::to_string(width) + "x" + std::to_string(height));
  }
  if (color.size() != n) {
    throw FrameCodecError("frame: colour has " + std::to_string(color.size()) + " pixels, expected " +
                          std::to_string(width) + "x" + std::to_string(height));
  }
}

DepthEncoding parse_depth_encoding(const std::string& name) {
  if (name == "raw") return DepthEncoding::kRaw;
  if (name == "zlib") return DepthEncoding::kZlib;
  if (name == "rvl") return DepthEncoding::kRvl;
  throw std::invalid_argument("depth encoding '" + name + "' is not one of raw|zlib|rvl");
}

ColorEncoding parse_color_encoding(const std::string& name) {
  if (name == "raw") return ColorEncoding::kRaw;
  if (name == "jpeg") return ColorEncoding::kJpeg;
  if (name == "png") return ColorEncoding::kPng;
  throw std::invalid_argument("colour encoding '" + name + "' is not one of raw|jpeg|png");
}

std::string to_string(DepthEncoding encoding) {
  switch (encoding) {
    case DepthEncoding::kZlib:
      return "zlib";
    case DepthEncoding::kRvl:
      return "rvl";
    case DepthEncoding::kRaw:
      break;
  }
  return "raw";
}

std::string to_string(ColorEncoding encoding) {
  switch (encoding) {
    case ColorEncoding::kJpeg:
      return "jpeg";
    case ColorEncoding::kPng:
      return "png";
    case ColorEncoding::kRaw:
      break;
  }
  return "raw";
}

void EncodeOptions::validate() const {
  if (depth != DepthEncoding::kRaw && depth != DepthEncoding::kZlib && depth != DepthEncoding::kRvl) {
    throw std::invalid_argument("EncodeOptions.depth must be raw, zlib or rvl");
  }
  if (color != ColorEncoding::kRaw && color != ColorEncoding::kJpeg && color != ColorEncoding::kPng) {
    throw std::invalid_argument("EncodeOptions.color must be raw, jpeg or png");
  }
  if (jpeg_quality < 1 || jpeg_quality > 100) {
    throw std::invalid_argument("EncodeOptions.jpeg_quality " + std::to_string(jpeg_quality) +
                                " is out of range [1, 100]");
  }
  if (zlib_level < 0 || zlib_level > 9) {
    throw std::invalid_argument("EncodeOptions.zlib_level " + std::to_string(zlib_level) + " is out of range [0, 9]");
  }
}

std::vector<std::uint8_t> depth_to_bytes(const std::vector<std::uint16_t>& depth_mm) {
  std::vector<std::uint8_t> bytes(depth_mm.size() * 2);
  for (std::size_t i = 0; i < depth_mm.size(); ++i) {
    bytes[2 * i] = static_cast<std::uint8_t>(depth_mm[i] & 0xff);
    bytes[2 * i + 1] = static_cast<std::uint8_t>(depth_mm[i] >> 8);
  }
  return bytes;
}

std::vector<std::uint8_t> compress_zlib(const std::vector<std::uint8_t>& bytes, int level) {
  if (level < 0 || level > 9) {
    throw std::invalid_argument("zlib level " + std::to_string(level) + " is out of range [0, 9]");
  }
  uLongf size = compressBound(static_cast<uLong>(bytes.size()));
  std::vector<std::uint8_t> out(size);
  if (compress2(out.data(), &size, bytes.data(), static_cast<uLong>(bytes.size()), level) != Z_OK) {
    throw FrameCodecError("zlib compression failed");
  }
  out.resize(size);
  return out;
}

std::vector<std::uint8_t> decompress_zlib(const std::uint8_t* data, std::size_t size, std::size_t expected_size) {
  std::vector<std::uint8_t> out(expected_size);
  uLongf out_size = static_cast<uLongf>(expected_size);
  uLong in_size = static_cast<uLong>(size);
  // uncompress2 rejects a null source even for zero bytes.
  static constexpr std::uint8_t kEmpty = 0;
  const int status = uncompress2(out.data(), &out_size, size == 0 ? &kEmpty : data, &in_size);
  // Z_BUF_ERROR with input left over: the stream holds more than expected; with all input
  // consumed: the stream ended early (truncated).
  if (status == Z_BUF_ERROR && in_size < size) {
    throw FrameCodecError("zlib data inflates to more than the expected " + std::to_string(expected_size) + " bytes");
  }
  if (status != Z_OK) {
    throw FrameCodecError("zlib data is truncated or corrupt (zlib status " + std::to_string(status) + ")");
  }
  if (out_size != expected_size) {
    throw FrameCodecError("zlib data inflates to " + std::to_string(out_size) + " bytes, expected " +
                          std::to_string(expected_size));
  }
  if (in_size != size) {
    throw FrameCodecError("zlib data has " + std::to_string(size - in_size) + " trailing bytes");
  }
  return out;
}

std::vector<std::uint8_t> encode_jpeg(const std::vector<Rgb8>& color, int width, int height, int quality) {
  check_frame_size("JPEG image", width, height);
  if (color.size() != pixel_count(width, height)) throw FrameCodecError("JPEG image: pixel count does not match size");
  if (quality < 1 || quality > 100) {
    throw std::invalid_argument("JPEG quality " + std::to_string(quality) + " is out of range [1, 100]");
  }
  JpegCompressState state;
  const bool ok = jpeg_compress_rgb(state, color.data(), width, height, quality);
  std::vector<std::uint8_t> out;
  if (ok) out.assign(state.buffer, state.buffer + state.size);
  std::free(state.buffer);
  if (!ok) throw FrameCodecError(std::string("JPEG encoding failed: ") + state.error.message);
  return out;
}

std::vector<Rgb8> decode_jpeg(const std::uint8_t* data, std::size_t size, int width, int height) {
  check_frame_size("JPEG image", width, height);
  if (size == 0 || data == nullptr) throw FrameCodecError("JPEG data is empty");
  if (size > std::numeric_limits<unsigned long>::max()) throw FrameCodecError("JPEG data is too large");
  std::vector<Rgb8> out(pixel_count(width, height));
  JpegDecompressState state;
  if (!jpeg_decompress_rgb(state, data, size, width, height, out.data())) {
    throw FrameCodecError(std::string("JPEG data is corrupt or truncated: ") + state.error.message);
  }
  return out;
}

frame_t encode_frame(const Frame& frame, const EncodeOptions& options, std::int64_t seq, const std::string& source,
                     std::int64_t utime) {
  options.validate();
  frame.validate();
  frame_t message{};  // the envelope too: zero until publish_message stamps it
  message.utime = utime;
  message.capture_utime = frame.capture_utime;
  message.seq = seq;
  message.source = source;
  message.width = frame.width;
  message.height = frame.height;
  message.fx = frame.fx;
  message.fy = frame.fy;
  message.cx = frame.cx;
  message.cy = frame.cy;

  message.depth_encoding = static_cast<std::int8_t>(options.depth);
  std::vector<std::uint8_t> depth =
      options.depth == DepthEncoding::kRvl ? encode_depth_rvl(frame.depth_mm) : depth_to_bytes(frame.depth_mm);
  if (options.depth == DepthEncoding::kZlib) depth = compress_zlib(depth, options.zlib_level);
  message.depth_data.assign(depth.begin(), depth.end());
  message.depth_size = static_cast<std::int32_t>(message.depth_data.size());

  message.color_encoding = static_cast<std::int8_t>(options.color);
  switch (options.color) {
    case ColorEncoding::kRaw: {
      const auto* bytes = reinterpret_cast<const std::uint8_t*>(frame.color.data());
      message.color_data.assign(bytes, bytes + frame.color.size() * sizeof(Rgb8));
      break;
    }
    case ColorEncoding::kJpeg: {
      const auto jpeg = encode_jpeg(frame.color, frame.width, frame.height, options.jpeg_quality);
      message.color_data.assign(jpeg.begin(), jpeg.end());
      break;
    }
    case ColorEncoding::kPng: {
      const auto png = encode_png_rgb(ImageRgb{frame.width, frame.height, frame.color}, options.zlib_level);
      message.color_data.assign(png.begin(), png.end());
      break;
    }
  }
  message.color_size = static_cast<std::int32_t>(message.color_data.size());
  return message;
}

namespace {

void decode_depth_part(const frame_t& message, const std::string& what, std::size_t n, Frame& frame) {
  const auto* depth_bytes = reinterpret_cast<const std::uint8_t*>(message.depth_data.data());
  std::vector<std::uint8_t> depth;
  switch (message.depth_encoding) {
    case frame_t::DEPTH_RAW:
      if (message.depth_data.size() != 2 * n) {
        throw FrameCodecError(what + ": raw depth has " + std::to_string(message.depth_data.size()) +
                              " bytes, expected " + std::to_string(2 * n) + " for " + std::to_string(message.width) +
                              "x" + std::to_string(message.height));
      }
      depth.assign(depth_bytes, depth_bytes + 2 * n);
      break;
    case frame_t::DEPTH_ZLIB:
      try {
        depth = decompress_zlib(depth_bytes, message.depth_data.size(), 2 * n);
      } catch (const FrameCodecError& e) {
        throw FrameCodecError(what + ": depth: " + e.what());
      }
      break;
    case frame_t::DEPTH_RVL:
      break;
    default:
      throw FrameCodecError(what + ": unknown depth_encoding " + std::to_string(message.depth_encoding) +
                            " (expected 0=raw, 1=zlib or 2=rvl)");
  }
  if (message.depth_encoding == frame_t::DEPTH_RVL) {
    try {
      frame.depth_mm = decode_depth_rvl(depth_bytes, message.depth_data.size(), n);
    } catch (const FrameCodecError& e) {
      throw FrameCodecError(what + ": depth: " + e.what());
    }
  } else {
    frame.depth_mm.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      frame.depth_mm[i] = static_cast<std::uint16_t>(depth[2 * i] | (depth[2 * i + 1] << 8));
    }
  }
}

void decode_color_part(const frame_t& message, const std::string& what, std::size_t n, Frame& frame) {
  const auto* color_bytes = reinterpret_cast<const std::uint8_t*>(message.color_data.data());
  switch (message.color_encoding) {
    case frame_t::COLOR_RAW:
      if (message.color_data.size() != 3 * n) {
        throw FrameCodecError(what + ": raw colour has " + std::to_string(message.color_data.size()) +
                              " bytes, expected " + std::to_string(3 * n) + " for " + std::to_string(message.width) +
                              "x" + std::to_string(message.height));
      }
      frame.color.resize(n);
      std::memcpy(frame.color.data(), color_bytes, 3 * n);
      break;
    case frame_t::COLOR_JPEG:
      try {
        frame.color = decode_jpeg(color_bytes, message.color_data.size(), message.width, message.height);
      } catch (const FrameCodecError& e) {
        throw FrameCodecError(what + ": colour: " + e.what());
      }
      break;
    case frame_t::COLOR_PNG: {
      std::uint32_t png_width = 0, png_height = 0;
      const std::size_t png_size = message.color_data.size();
      if (!png_header_size(color_bytes, png_size, png_width, png_height)) {
        throw FrameCodecError(what + ": colour: not PNG data (bad signature or header)");
      }
      if (png_width != static_cast<std::uint32_t>(message.width) ||
          png_height != static_cast<std::uint32_t>(message.height)) {
        throw FrameCodecError(what + ": colour: PNG is " + std::to_string(png_width) + "x" +
                              std::to_string(png_height) + ", expected " + std::to_string(message.width) + "x" +
                              std::to_string(message.height));
      }
      try {
        frame.color = decode_png_rgb(color_bytes, png_size).pixels;
      } catch (const ImageIoError& e) {
        throw FrameCodecError(what + ": colour: " + e.what());
      }
      break;
    }
    default:
      throw FrameCodecError(what + ": unknown color_encoding " + std::to_string(message.color_encoding) +
                            " (expected 0=raw, 1=jpeg or 2=png)");
  }
}

}  // namespace

Frame decode_frame(const frame_t& message, FrameParts parts, ThreadPool* pool) {
  const std::string what = "frame_t seq " + std::to_string(message.seq);
  check_frame_size(what, message.width, message.height);
  check_intrinsics(what, message.fx, message.fy, message.cx, message.cy);
  if (message.depth_size < 0 || static_cast<std::size_t>(message.depth_size) != message.depth_data.size()) {
    throw FrameCodecError(what + ": depth_size " + std::to_string(message.depth_size) + " does not match " +
                          std::to_string(message.depth_data.size()) + " depth bytes");
  }
  if (message.color_size < 0 || static_cast<std::size_t>(message.color_size) != message.color_data.size()) {
    throw FrameCodecError(what + ": color_size " + std::to_string(message.color_size) + " does not match " +
                          std::to_string(message.color_data.size()) + " colour bytes");
  }
  Frame frame;
  frame.capture_utime = message.capture_utime;
  frame.width = message.width;
  frame.height = message.height;
  frame.fx = message.fx;
  frame.fy = message.fy;
  frame.cx = message.cx;
  frame.cy = message.cy;
  const std::size_t n = pixel_count(message.width, message.height);

  if (parts == FrameParts::kDepthOnly) {
    decode_depth_part(message, what, n, frame);
    if (message.color_encoding != frame_t::COLOR_RAW && message.color_encoding != frame_t::COLOR_JPEG &&
        message.color_encoding != frame_t::COLOR_PNG) {
      throw FrameCodecError(what + ": unknown color_encoding " + std::to_string(message.color_encoding) +
                            " (expected 0=raw, 1=jpeg or 2=png)");
    }
    return frame;
  }
  // Depth and colour are independent: with a pool they decode side by side.
  const auto decode_part = [&message, &what, n, &frame](std::size_t part) {
    if (part == 0) {
      decode_depth_part(message, what, n, frame);
    } else {
      decode_color_part(message, what, n, frame);
    }
  };
  if (pool != nullptr) {
    pool->run(2, decode_part);
  } else {
    decode_part(0);
    decode_part(1);
  }
  return frame;
}

}  // namespace mfot::service
