#pragma once
// Decodes one frame on its own thread while the caller works on another: the preprocess service
// decodes the next queued frame while it preprocesses the current one, so in lockstep with two or
// more frames in flight the decoding (RVL depth and JPEG colour, a fifth of its time a frame) leaves
// the serial path that bounds the group's rate. Decoding is a pure function of the message, so the
// frame is the same as decode_frame's on the caller's thread.
//
// One frame at a time: start() hands a message over (the caller keeps it alive and unchanged until
// take() or the destructor), take() waits for its frame or rethrows its FrameCodecError.

#include <condition_variable>
#include <cstdint>
#include <exception>
#include <mutex>
#include <optional>
#include <thread>

#include "mfot/frame_t.hpp"
#include "mfot/service/frame_codec.hpp"

namespace mfot::service {

class DecodeAhead {
 public:
  DecodeAhead();
  DecodeAhead(const DecodeAhead&) = delete;
  DecodeAhead& operator=(const DecodeAhead&) = delete;
  ~DecodeAhead();  // waits for a frame being decoded

  // Starts decoding `message` (depth and colour). Throws std::logic_error when a frame started
  // earlier was not taken.
  void start(const frame_t& message);
  // The sequence number of the frame started and not yet taken, if any.
  std::optional<std::int64_t> started_seq() const { return started_seq_; }
  // Waits for the started frame; rethrows its decoding error. Throws std::logic_error when none was started.
  Frame take();

 private:
  void run();

  std::mutex mutex_;
  std::condition_variable changed_;
  const frame_t* message_ = nullptr;  // to decode; guarded by mutex_
  bool done_ = false;                 // the result below is ready; guarded by mutex_
  bool stop_ = false;
  Frame frame_;
  std::exception_ptr error_;
  std::optional<std::int64_t> started_seq_;  // caller's thread only
  std::thread thread_;
};

}  // namespace mfot::service
