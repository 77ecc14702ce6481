#pragma once
// The preprocess service's frames in waiting, transport-free: admitted frames queue in arrival
// order, at most `capacity` (beyond it the oldest is dropped, counted by the caller); the oldest is
// decoded for the caller and, with decode-ahead, the one behind it is decoded on a thread of its own
// (DecodeAhead) while the caller preprocesses the oldest, so in lockstep with two or more frames in
// flight the decoding leaves the path that bounds the group's rate. The frames are the same with and
// without decode-ahead.
//
// Per frame: incoming() is filled by the receiver and push_incoming() queues it; the worker calls
// decode_front() (the oldest message and its frame, the next one started meanwhile), preprocesses,
// then pop_front().

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>

#include "mfot/frame_t.hpp"
#include "mfot/service/decode_ahead.hpp"
#include "mfot/service/frame_codec.hpp"
#include "mfot/thread_pool.hpp"

namespace mfot::service {

class PreprocessQueue {
 public:
  // capacity >= 1. threads: preprocess.threads, >= 1; from 2 on the oldest frame's depth and colour
  // decode side by side and the next frame is decoded ahead, below it all decoding is on the caller's thread.
  PreprocessQueue(std::size_t capacity, int threads);
  PreprocessQueue(const PreprocessQueue&) = delete;
  PreprocessQueue& operator=(const PreprocessQueue&) = delete;

  // The message to receive the next frame into (it keeps the capacity of a frame done with).
  frame_t& incoming() { return incoming_; }
  // Queues incoming(); true when the oldest frame was dropped to make room. Not between
  // decode_front() and pop_front() (std::logic_error): the oldest frame is then in use.
  bool push_incoming();

  bool empty() const { return pending_.empty(); }
  std::size_t size() const { return pending_.size(); }
  const frame_t& front() const { return pending_.front(); }

  // The oldest frame decoded (taken from the decode-ahead when it was decoded there), and the one
  // behind it started. Throws FrameCodecError for an undecodable oldest frame (pop it then).
  Frame decode_front();
  // Done with the oldest frame; waits for the one behind it to be decoded (then dropping it is safe).
  void pop_front();

 private:
  std::size_t capacity_;
  ThreadPool decode_pool_;
  std::deque<frame_t> pending_;  // in arrival order
  frame_t incoming_;
  std::optional<Frame> front_frame_;  // pending_.front() decoded ahead
  bool in_use_ = false;               // between decode_front() and pop_front()
  // Declared last, so it is destroyed first: it may still be decoding a queued message.
  std::unique_ptr<DecodeAhead> ahead_;
};

}  // namespace mfot::service
