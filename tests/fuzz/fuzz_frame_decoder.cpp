// Fuzz target: frame_t wire bytes as preprocess and merger receive them on MFOT_FRAME:
// decode_message (lcm decode, counted when malformed), then decode_frame (sizes, intrinsics,
// zlib depth, raw/JPEG/PNG colour).
// Contract checked: every input is either rejected (decode_message returns false and counts it,
// or decode_frame throws FrameCodecError) or becomes a frame that passes Frame::validate();
// nothing else may happen (other exceptions, crashes, sanitizer reports, huge allocations).

#include <cstddef>
#include <cstdint>
#include <vector>

#include "fuzz_support.hpp"
#include "mfot/frame_t.hpp"
#include "mfot/service/frame_codec.hpp"
#include "mfot/service/lcm_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mfot::service;
  mfot::fuzz::silence_logging();
  // A private copy: lcm::ReceiveBuffer takes a mutable pointer.
  std::vector<std::uint8_t> bytes(data, data + size);
  const lcm::ReceiveBuffer buffer{bytes.data(), static_cast<std::uint32_t>(bytes.size()), 0};
  MalformedCounter malformed;
  mfot::frame_t message;
  if (!decode_message(&buffer, channel::kFrame, message, malformed)) {
    MFOT_FUZZ_CHECK(malformed.total() == 1);
    return 0;
  }
  MFOT_FUZZ_CHECK(malformed.total() == 0);
  Frame frame;
  try {
    frame = decode_frame(message);
  } catch (const FrameCodecError&) {
    return 0;
  }
  try {
    frame.validate();
  } catch (const FrameCodecError&) {
    mfot::fuzz::fail("decode_frame returned a frame that fails Frame::validate()");
  }
  MFOT_FUZZ_CHECK(frame.width == message.width && frame.height == message.height);
  return 0;
}
