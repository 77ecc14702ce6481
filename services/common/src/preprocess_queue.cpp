#include "mfot/service/preprocess_queue.hpp"

#include <stdexcept>
#include <string>
#include <utility>

namespace mfot::service {

PreprocessQueue::PreprocessQueue(std::size_t capacity, int threads)
    : capacity_(capacity),
      decode_pool_(threads >= 2 ? 2 : 1),
      ahead_(threads >= 2 ? std::make_unique<DecodeAhead>() : nullptr) {
  if (capacity_ < 1) throw std::invalid_argument("PreprocessQueue: capacity must be >= 1");
  if (threads < 1) throw std::invalid_argument("PreprocessQueue: threads must be >= 1");
}

bool PreprocessQueue::push_incoming() {
  if (in_use_) throw std::logic_error("PreprocessQueue::push_incoming: between decode_front and pop_front");
  pending_.push_back(std::move(incoming_));
  if (pending_.size() <= capacity_) return false;
  pending_.pop_front();  // no frame is being decoded ahead now: pop_front took it
  front_frame_.reset();
  return true;
}

Frame PreprocessQueue::decode_front() {
  if (pending_.empty()) throw std::logic_error("PreprocessQueue::decode_front: no frame queued");
  in_use_ = true;
  Frame frame;
  if (front_frame_) {
    frame = std::move(*front_frame_);
    front_frame_.reset();
  } else {
    frame = decode_frame(pending_.front(), FrameParts::kDepthAndColor, &decode_pool_);
  }
  if (ahead_ && pending_.size() >= 2) ahead_->start(pending_[1]);
  return frame;
}

void PreprocessQueue::pop_front() {
  if (pending_.empty()) throw std::logic_error("PreprocessQueue::pop_front: no frame queued");
  in_use_ = false;
  incoming_ = std::move(pending_.front());  // keeps its buffers' capacity for the next frame
  pending_.pop_front();
  if (ahead_ && ahead_->started_seq()) {
    try {
      front_frame_ = ahead_->take();
    } catch (const FrameCodecError&) {
      front_frame_.reset();  // decode_front decodes it again and reports why
    }
  }
}

}  // namespace mfot::service
