#pragma once
// The frames preprocess takes from MFOT_FRAME: the boundary checks of an untrusted frame_t before it is
// queued. Steps, per admit():
//   1. sizes: the encoded depth and colour must be plausible for the declared image
//      (implausible_frame_sizes);
//   2. sequence: seq >= 0 and, from the capture process that sent the last admitted frame
//      (envelope.sender), above that frame's seq; a new process (a restarted capture) may start again.
// Transport-free: the service main records a refusal in its malformed counter.

#include <cstdint>
#include <optional>
#include <string>

#include "mfot/frame_t.hpp"

namespace mfot::service {

class FrameGate {
 public:
  struct Refusal {
    std::string kind;    // "invalid frame" or "frame seq not increasing"
    std::string detail;  // what was wrong, with the values
  };

  // nullopt: the frame is admitted and becomes the last one; else why it is refused (nothing changes).
  std::optional<Refusal> admit(const frame_t& frame);

 private:
  std::int64_t last_sender_ = 0;  // envelope.sender of the last frame admitted (0: none yet)
  std::int64_t last_seq_ = -1;    // and its seq
};

}  // namespace mfot::service
