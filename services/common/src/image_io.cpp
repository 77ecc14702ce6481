#include "mfot/service/image_io.hpp"

#include <png.h>

#include <bit>
#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <new>

namespace mfot::service {
namespace {

// libpng reports errors through a callback that must not return; it long-jumps back to the
// setjmp in decode_png / encode_png. Those functions create no object with a non-trivial
// destructor after their setjmp (all containers are the caller's), so the jump skips nothing.
struct PngContext {
  const std::uint8_t* source = nullptr;  // memory input
  std::size_t source_size = 0;
  std::size_t source_offset = 0;
  std::vector<std::uint8_t>* sink = nullptr;  // memory output
  char message[256] = {};
};

extern "C" void on_png_error(png_structp png, png_const_charp text) {
  auto* context = static_cast<PngContext*>(png_get_error_ptr(png));
  std::snprintf(context->message, sizeof context->message, "%s", text);
  png_longjmp(png, 1);
}

// Warnings concern ancillary chunks (colour profiles, text); the pixels are still valid.
extern "C" void on_png_warning(png_structp, png_const_charp) {}

extern "C" void on_png_read(png_structp png, png_bytep out, png_size_t count) {
  auto* context = static_cast<PngContext*>(png_get_io_ptr(png));
  if (count > context->source_size - context->source_offset) png_error(png, "truncated PNG data");
  std::memcpy(out, context->source + context->source_offset, count);
  context->source_offset += count;
}

extern "C" void on_png_write(png_structp png, png_bytep in, png_size_t count) {
  auto* context = static_cast<PngContext*>(png_get_io_ptr(png));
  bool stored = true;
  try {
    context->sink->insert(context->sink->end(), in, in + count);
  } catch (const std::bad_alloc&) {
    stored = false;
  }
  if (!stored) png_error(png, "out of memory while encoding PNG");
}

extern "C" void on_png_flush(png_structp) {}

enum class PixelLayout { kGray16, kRgb8 };

const char* color_type_name(int color_type) {
  switch (color_type) {
    case PNG_COLOR_TYPE_GRAY:
      return "greyscale";
    case PNG_COLOR_TYPE_GRAY_ALPHA:
      return "greyscale+alpha";
    case PNG_COLOR_TYPE_PALETTE:
      return "palette";
    case PNG_COLOR_TYPE_RGB:
      return "RGB";
    case PNG_COLOR_TYPE_RGB_ALPHA:
      return "RGBA";
    default:
      return "unknown colour type";
  }
}

// Decodes from `file` (when not null) or from context.source into `bytes` (16-bit values in
// native byte order, or packed RGB). Returns false with context.message set on any failure.
bool decode_png(PngContext& context, std::FILE* file, PixelLayout layout, int& width, int& height,
                std::vector<std::uint8_t>& bytes, std::vector<png_bytep>& rows) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &context, on_png_error, on_png_warning);
  if (png == nullptr) {
    std::snprintf(context.message, sizeof context.message, "cannot create PNG reader");
    return false;
  }
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    std::snprintf(context.message, sizeof context.message, "cannot create PNG reader");
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  if (file != nullptr) {
    png_init_io(png, file);
  } else {
    png_set_read_fn(png, &context, on_png_read);
  }
  png_set_user_limits(png, kMaxImageSide, kMaxImageSide);
  png_read_info(png, info);
  png_uint_32 w = 0, h = 0;
  int bit_depth = 0, color_type = 0;
  png_get_IHDR(png, info, &w, &h, &bit_depth, &color_type, nullptr, nullptr, nullptr);
  std::size_t bytes_per_pixel = 3;
  if (layout == PixelLayout::kGray16) {
    if (bit_depth != 16 || color_type != PNG_COLOR_TYPE_GRAY) {
      std::snprintf(context.message, sizeof context.message, "expected a 16-bit greyscale PNG, got %d-bit %s",
                    bit_depth, color_type_name(color_type));
      png_destroy_read_struct(&png, &info, nullptr);
      return false;
    }
    if constexpr (std::endian::native == std::endian::little) png_set_swap(png);
    bytes_per_pixel = 2;
  } else {
    if (color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if (color_type == PNG_COLOR_TYPE_GRAY && bit_depth < 8) png_set_expand_gray_1_2_4_to_8(png);
    if (bit_depth == 16) png_set_strip_16(png);
    if ((color_type & PNG_COLOR_MASK_ALPHA) != 0) png_set_strip_alpha(png);
    if (color_type == PNG_COLOR_TYPE_GRAY || color_type == PNG_COLOR_TYPE_GRAY_ALPHA) png_set_gray_to_rgb(png);
  }
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  const std::size_t row_bytes = png_get_rowbytes(png, info);
  if (row_bytes != std::size_t{w} * bytes_per_pixel) {
    std::snprintf(context.message, sizeof context.message,
                  "unsupported PNG pixel layout (%zu bytes per row for %u pixels)", row_bytes,
                  static_cast<unsigned>(w));
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  bool allocated = true;
  try {
    bytes.resize(row_bytes * h);
    rows.resize(h);
  } catch (const std::bad_alloc&) {
    allocated = false;
  }
  if (!allocated) {
    std::snprintf(context.message, sizeof context.message, "out of memory for a %ux%u image", static_cast<unsigned>(w),
                  static_cast<unsigned>(h));
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  for (png_uint_32 y = 0; y < h; ++y) rows[y] = bytes.data() + y * row_bytes;
  png_read_image(png, rows.data());
  png_read_end(png, nullptr);
  width = static_cast<int>(w);
  height = static_cast<int>(h);
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

// Encodes `pixels` (16-bit native-order values or packed RGB) to `file` or context.sink; without
// `filter_rows` every row is stored unfiltered (libpng otherwise tries every filter per row).
bool encode_png(PngContext& context, std::FILE* file, PixelLayout layout, int width, int height,
                const std::uint8_t* pixels, int level, bool filter_rows, std::vector<png_bytep>& rows) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &context, on_png_error, on_png_warning);
  if (png == nullptr) {
    std::snprintf(context.message, sizeof context.message, "cannot create PNG writer");
    return false;
  }
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_write_struct(&png, nullptr);
    std::snprintf(context.message, sizeof context.message, "cannot create PNG writer");
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  if (file != nullptr) {
    png_init_io(png, file);
  } else {
    png_set_write_fn(png, &context, on_png_write, on_png_flush);
  }
  png_set_compression_level(png, level);
  if (!filter_rows) png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_NONE);
  const bool gray16 = layout == PixelLayout::kGray16;
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), gray16 ? 16 : 8,
               gray16 ? PNG_COLOR_TYPE_GRAY : PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  if (gray16 && std::endian::native == std::endian::little) png_set_swap(png);
  const std::size_t row_bytes = static_cast<std::size_t>(width) * (gray16 ? 2 : 3);
  // libpng copies each row before transforming it, so the caller's pixels are only read.
  for (int y = 0; y < height; ++y) rows[static_cast<std::size_t>(y)] = const_cast<png_bytep>(pixels + y * row_bytes);
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

void check_dimensions(const std::string& name, int width, int height, std::size_t pixel_count) {
  if (width <= 0 || height <= 0 || width > kMaxImageSide || height > kMaxImageSide) {
    throw ImageIoError(name + ": invalid image size " + std::to_string(width) + "x" + std::to_string(height) +
                       " (each side must be 1.." + std::to_string(kMaxImageSide) + ")");
  }
  if (pixel_count != static_cast<std::size_t>(width) * static_cast<std::size_t>(height)) {
    throw ImageIoError(name + ": image has " + std::to_string(pixel_count) + " pixels, expected " +
                       std::to_string(width) + "x" + std::to_string(height));
  }
}

void check_level(int level) {
  if (level < 0 || level > 9) {
    throw std::invalid_argument("PNG compression level " + std::to_string(level) + " is out of range [0, 9]");
  }
}

class File {
 public:
  File(const std::string& path, const char* mode) : handle_(std::fopen(path.c_str(), mode)) {}
  File(const File&) = delete;
  File& operator=(const File&) = delete;
  ~File() {
    if (handle_ != nullptr) std::fclose(handle_);
  }
  std::FILE* get() const { return handle_; }
  // Closes and reports whether every buffered byte reached the file.
  bool close() {
    const bool ok = std::fflush(handle_) == 0 && std::ferror(handle_) == 0;
    const bool closed = std::fclose(handle_) == 0;
    handle_ = nullptr;
    return ok && closed;
  }

 private:
  std::FILE* handle_;
};

std::string errno_text() { return std::strerror(errno); }

template <class Image, class Pixel>
Image to_image(int width, int height, const std::vector<std::uint8_t>& bytes) {
  Image image;
  image.width = width;
  image.height = height;
  image.pixels.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  static_assert(sizeof(Pixel) == 2 || sizeof(Pixel) == 3);
  std::memcpy(image.pixels.data(), bytes.data(), image.pixels.size() * sizeof(Pixel));
  return image;
}

static_assert(sizeof(Rgb8) == 3, "Rgb8 must be packed RGB");

template <class Image, class Pixel>
Image read_file(const std::string& path, PixelLayout layout) {
  File file(path, "rb");
  if (file.get() == nullptr) throw ImageIoError(path + ": cannot open: " + errno_text());
  PngContext context;
  std::vector<std::uint8_t> bytes;
  std::vector<png_bytep> rows;
  int width = 0, height = 0;
  if (!decode_png(context, file.get(), layout, width, height, bytes, rows)) {
    throw ImageIoError(path + ": " + context.message);
  }
  return to_image<Image, Pixel>(width, height, bytes);
}

template <class Image, class Pixel>
Image decode_memory(const std::uint8_t* data, std::size_t size, PixelLayout layout) {
  PngContext context;
  context.source = data;
  context.source_size = data == nullptr ? 0 : size;
  std::vector<std::uint8_t> bytes;
  std::vector<png_bytep> rows;
  int width = 0, height = 0;
  if (!decode_png(context, nullptr, layout, width, height, bytes, rows)) {
    throw ImageIoError(std::string("PNG data: ") + context.message);
  }
  return to_image<Image, Pixel>(width, height, bytes);
}

template <class Image>
void write_file(const std::string& path, const Image& image, PixelLayout layout, PngCompression compression) {
  check_dimensions(path, image.width, image.height, image.pixels.size());
  File file(path, "wb");
  if (file.get() == nullptr) throw ImageIoError(path + ": cannot create: " + errno_text());
  PngContext context;
  std::vector<png_bytep> rows(static_cast<std::size_t>(image.height));
  errno = 0;
  const bool encoded =
      encode_png(context, file.get(), layout, image.width, image.height,
                 reinterpret_cast<const std::uint8_t*>(image.pixels.data()),
                 compression == PngCompression::kFast ? 1 : 6, compression == PngCompression::kSmall, rows);
  const int write_errno = errno;  // of the failed write inside libpng, if any
  errno = 0;
  const bool closed = file.close();
  const int close_errno = errno != 0 ? errno : write_errno;
  if (!encoded || !closed) {
    std::remove(path.c_str());
    // libpng says only "Write Error" when a write fails: the system's reason is errno's.
    std::string why = encoded ? std::string(std::strerror(close_errno)) : std::string(context.message);
    if (!encoded && write_errno != 0) why += std::string(" (") + std::strerror(write_errno) + ")";
    throw ImageIoError(path + ": cannot write PNG: " + why);
  }
}

template <class Image>
std::vector<std::uint8_t> encode_memory(const Image& image, PixelLayout layout, int level) {
  check_level(level);
  check_dimensions("PNG data", image.width, image.height, image.pixels.size());
  std::vector<std::uint8_t> out;
  PngContext context;
  context.sink = &out;
  std::vector<png_bytep> rows(static_cast<std::size_t>(image.height));
  if (!encode_png(context, nullptr, layout, image.width, image.height,
                  reinterpret_cast<const std::uint8_t*>(image.pixels.data()), level, true, rows)) {
    throw ImageIoError(std::string("PNG data: cannot encode: ") + context.message);
  }
  return out;
}

}  // namespace

Image16 read_png16(const std::string& path) { return read_file<Image16, std::uint16_t>(path, PixelLayout::kGray16); }
ImageRgb read_png_rgb(const std::string& path) { return read_file<ImageRgb, Rgb8>(path, PixelLayout::kRgb8); }

void write_png16(const std::string& path, const Image16& image, PngCompression compression) {
  write_file(path, image, PixelLayout::kGray16, compression);
}
void write_png_rgb(const std::string& path, const ImageRgb& image) {
  write_file(path, image, PixelLayout::kRgb8, PngCompression::kSmall);
}

std::vector<std::uint8_t> encode_png16(const Image16& image, int level) {
  return encode_memory(image, PixelLayout::kGray16, level);
}
std::vector<std::uint8_t> encode_png_rgb(const ImageRgb& image, int level) {
  return encode_memory(image, PixelLayout::kRgb8, level);
}
Image16 decode_png16(const std::uint8_t* data, std::size_t size) {
  return decode_memory<Image16, std::uint16_t>(data, size, PixelLayout::kGray16);
}
ImageRgb decode_png_rgb(const std::uint8_t* data, std::size_t size) {
  return decode_memory<ImageRgb, Rgb8>(data, size, PixelLayout::kRgb8);
}

}  // namespace mfot::service
