#include "mfot/capture/frame_source.hpp"

namespace mfot::capture {

void FrameSource::seek(std::int64_t index) {
  if (index < 0) throw CaptureError("start frame " + std::to_string(index) + " must be >= 0");
  for (std::int64_t i = 0; i < index; ++i) {
    if (!next()) {
      throw CaptureError(name() + ": start frame " + std::to_string(index) + " is beyond the end (" +
                         std::to_string(i) + " frames)");
    }
  }
}

}  // namespace mfot::capture
