#include "mfot/service/frame_gate.hpp"

#include "mfot/service/frame_codec.hpp"

namespace mfot::service {

std::optional<FrameGate::Refusal> FrameGate::admit(const frame_t& frame) {
  if (auto why = implausible_frame_sizes(frame)) return Refusal{"invalid frame", *why};
  if (frame.seq < 0 || (last_sender_ != 0 && frame.envelope.sender == last_sender_ && frame.seq <= last_seq_)) {
    return Refusal{"frame seq not increasing", "seq " + std::to_string(frame.seq) + " after " +
                                                   std::to_string(last_seq_) + " from the same capture"};
  }
  last_sender_ = frame.envelope.sender;
  last_seq_ = frame.seq;
  return std::nullopt;
}

}  // namespace mfot::service
