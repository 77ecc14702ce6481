#include "mfot/service/depth_rvl.hpp"

#include <string>

#include "mfot/service/frame_codec.hpp"

namespace mfot::service {
namespace {

class NibbleWriter {
 public:
  explicit NibbleWriter(std::vector<std::uint8_t>& out) : out_(out) {}

  void put(std::uint32_t value) {
    do {
      std::uint32_t nibble = value & 7u;
      value >>= 3;
      if (value != 0) nibble |= 8u;
      put_nibble(static_cast<std::uint8_t>(nibble));
    } while (value != 0);
  }

  // A half-filled last byte keeps a zero low nibble.
  void finish() {
    if (half_) out_.push_back(pending_);
    half_ = false;
  }

 private:
  void put_nibble(std::uint8_t nibble) {
    if (half_) {
      out_.push_back(static_cast<std::uint8_t>(pending_ | nibble));
    } else {
      pending_ = static_cast<std::uint8_t>(nibble << 4);
    }
    half_ = !half_;
  }

  std::vector<std::uint8_t>& out_;
  std::uint8_t pending_ = 0;
  bool half_ = false;
};

class NibbleReader {
 public:
  NibbleReader(const std::uint8_t* data, std::size_t size) : data_(data), nibbles_(2 * size) {}

  std::uint32_t get() {
    // Fast path away from the end: a number has at most 11 nibbles, so none is checked.
    if (nibbles_ - next_ >= 11) {
      std::uint32_t value = 0;
      for (int shift = 0; shift <= 30; shift += 3) {
        const std::uint32_t nibble = (data_[next_ >> 1] >> ((~next_ & 1u) << 2)) & 0xfu;
        ++next_;
        value |= (nibble & 7u) << shift;
        if ((nibble & 8u) == 0) return value;
      }
      throw FrameCodecError("RVL depth: a number has more than 11 groups");
    }
    std::uint32_t value = 0;
    for (int shift = 0;; shift += 3) {
      if (shift > 30) throw FrameCodecError("RVL depth: a number has more than 11 groups");
      if (next_ == nibbles_) throw FrameCodecError("RVL depth: the stream ends early (truncated)");
      const std::uint8_t byte = data_[next_ / 2];
      const std::uint32_t nibble = (next_ % 2 == 0) ? (byte >> 4) : (byte & 0xfu);
      ++next_;
      value |= (nibble & 7u) << shift;
      if ((nibble & 8u) == 0) return value;
    }
  }

  // After the last pixel only the zero padding nibble of a half-filled byte may remain.
  void expect_end() const {
    const std::size_t left = nibbles_ - next_;
    if (left > 1 || (left == 1 && (data_[next_ / 2] & 0xfu) != 0)) {
      throw FrameCodecError("RVL depth: " + std::to_string(left / 2) + " trailing bytes after the last pixel");
    }
  }

 private:
  const std::uint8_t* data_;
  std::size_t nibbles_;
  std::size_t next_ = 0;
};

}  // namespace

std::vector<std::uint8_t> encode_depth_rvl(const std::vector<std::uint16_t>& depth_mm) {
  std::vector<std::uint8_t> out;
  out.reserve(depth_mm.size() / 2);
  NibbleWriter writer(out);
  const std::size_t n = depth_mm.size();
  std::int32_t previous = 0;
  std::size_t i = 0;
  while (i < n) {
    std::size_t zeros = 0;
    while (i + zeros < n && depth_mm[i + zeros] == 0) ++zeros;
    i += zeros;
    std::size_t nonzeros = 0;
    while (i + nonzeros < n && depth_mm[i + nonzeros] != 0) ++nonzeros;
    writer.put(static_cast<std::uint32_t>(zeros));
    writer.put(static_cast<std::uint32_t>(nonzeros));
    for (const std::size_t end = i + nonzeros; i < end; ++i) {
      const std::int32_t value = depth_mm[i];
      const std::int32_t delta = value - previous;
      writer.put(static_cast<std::uint32_t>((delta << 1) ^ (delta >> 31)));  // zigzag: small |delta|, few bits
      previous = value;
    }
  }
  writer.finish();
  return out;
}

std::vector<std::uint16_t> decode_depth_rvl(const std::uint8_t* data, std::size_t size, std::size_t pixels) {
  std::vector<std::uint16_t> depth(pixels, 0);
  NibbleReader reader(data, size);
  std::int64_t previous = 0;
  std::size_t i = 0;
  while (i < pixels) {
    const std::size_t zeros = reader.get();
    const std::size_t nonzeros = reader.get();
    if (zeros > pixels - i || nonzeros > pixels - i - zeros) {
      throw FrameCodecError("RVL depth: a run of " + std::to_string(zeros + nonzeros) + " pixels at pixel " +
                            std::to_string(i) + " passes the image's " + std::to_string(pixels) + " pixels");
    }
    if (zeros == 0 && nonzeros == 0) throw FrameCodecError("RVL depth: an empty run at pixel " + std::to_string(i));
    i += zeros;
    for (const std::size_t end = i + nonzeros; i < end; ++i) {
      const std::uint32_t zigzag = reader.get();
      const std::int64_t delta = static_cast<std::int64_t>(zigzag >> 1) ^ -static_cast<std::int64_t>(zigzag & 1u);
      const std::int64_t value = previous + delta;
      if (value < 1 || value > 65535) {
        throw FrameCodecError("RVL depth: pixel " + std::to_string(i) + " decodes to " + std::to_string(value) +
                              ", outside [1, 65535]");
      }
      depth[i] = static_cast<std::uint16_t>(value);
      previous = value;
    }
  }
  reader.expect_end();
  return depth;
}

}  // namespace mfot::service
