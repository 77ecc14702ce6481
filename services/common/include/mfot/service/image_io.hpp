#pragma once
// PNG reading and writing (libpng) for 16-bit greyscale images (depth, labels) and 8-bit RGB
// images (colour), from and to files or memory. Every failure throws ImageIoError naming the file
// (or "<memory>") and the reason; corrupt or truncated data never reaches the caller as pixels.

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "mfot/types.hpp"

namespace mfot::service {

struct ImageIoError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Row-major 16-bit greyscale image; values are kept exactly (no gamma or scaling).
struct Image16 {
  int width = 0;
  int height = 0;
  std::vector<std::uint16_t> pixels;  // width * height
};

// Row-major 8-bit RGB image.
struct ImageRgb {
  int width = 0;
  int height = 0;
  std::vector<Rgb8> pixels;  // width * height
};

// Largest accepted image side in pixels; protects against absurd headers in corrupt files.
inline constexpr int kMaxImageSide = 16384;

// Reads a 16-bit greyscale PNG; any other bit depth or colour type is an error (depth and label
// images must not be silently converted).
Image16 read_png16(const std::string& path);
// Reads any PNG as 8-bit RGB: palette and grey are expanded, 16-bit is reduced, alpha dropped.
ImageRgb read_png_rgb(const std::string& path);

// How hard a PNG file is compressed. kSmall: zlib level 6 with libpng's adaptive row filters.
// kFast: zlib level 1 without row filters, for images written every frame (label images): a
// 640x480 label image takes about 1.7 ms instead of 9 ms and 7 kB instead of 3.6 kB
// (tests/benchmarks/bench_frame_path.cpp). Both are lossless.
enum class PngCompression { kSmall, kFast };

void write_png16(const std::string& path, const Image16& image, PngCompression compression = PngCompression::kSmall);
void write_png_rgb(const std::string& path, const ImageRgb& image);

// In-memory variants; `level` is the zlib compression level 0..9.
std::vector<std::uint8_t> encode_png16(const Image16& image, int level = 6);
std::vector<std::uint8_t> encode_png_rgb(const ImageRgb& image, int level = 6);
Image16 decode_png16(const std::uint8_t* data, std::size_t size);
ImageRgb decode_png_rgb(const std::uint8_t* data, std::size_t size);

}  // namespace mfot::service
