#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace mfot::service {

// Lossless depth coding after RVL (A. D. Wilson, "Fast Lossless Depth Image Compression", ISS
// 2017). A depth camera's image is smooth surfaces between runs of missing pixels (0), so the
// stream holds alternating run lengths of zero and non-zero pixels and, for each non-zero pixel,
// the zigzag-coded difference to the previous non-zero pixel; every number is written in 4-bit
// groups (3 value bits and a continuation bit), high nibble of each byte first. It compresses
// Kinect-like depth about as well as zlib at a fraction of zlib's time, which matters because every
// frame is encoded once and decoded by two services.
std::vector<std::uint8_t> encode_depth_rvl(const std::vector<std::uint16_t>& depth_mm);

// Decodes exactly `pixels` depth values. Throws FrameCodecError naming the problem when the stream
// is truncated, a run passes the last pixel, a value leaves [1, 65535], a number is too long, or
// bytes are left over.
std::vector<std::uint16_t> decode_depth_rvl(const std::uint8_t* data, std::size_t size, std::size_t pixels);

}  // namespace mfot::service
