#include "mfot/service/decode_ahead.hpp"

#include <stdexcept>
#include <utility>

namespace mfot::service {

DecodeAhead::DecodeAhead() : thread_([this] { run(); }) {}

DecodeAhead::~DecodeAhead() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

void DecodeAhead::start(const frame_t& message) {
  if (started_seq_) throw std::logic_error("DecodeAhead::start: the frame started before was not taken");
  {
    std::lock_guard lock(mutex_);
    message_ = &message;
    done_ = false;
  }
  started_seq_ = message.seq;
  changed_.notify_all();
}

Frame DecodeAhead::take() {
  if (!started_seq_) throw std::logic_error("DecodeAhead::take: no frame was started");
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [this] { return done_; });
  started_seq_.reset();
  done_ = false;
  if (error_) {
    const std::exception_ptr error = std::exchange(error_, nullptr);
    std::rethrow_exception(error);
  }
  return std::move(frame_);
}

void DecodeAhead::run() {
  std::unique_lock lock(mutex_);
  for (;;) {
    changed_.wait(lock, [this] { return stop_ || message_ != nullptr; });
    if (stop_) return;  // a frame not yet begun is not decoded
    const frame_t* message = std::exchange(message_, nullptr);
    lock.unlock();
    Frame frame;
    std::exception_ptr error;
    try {
      frame = decode_frame(*message);
    } catch (...) {
      error = std::current_exception();
    }
    lock.lock();
    frame_ = std::move(frame);
    error_ = error;
    done_ = true;
    changed_.notify_all();
  }
}

}  // namespace mfot::service
