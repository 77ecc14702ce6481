#include "mfot/service/background_queue.hpp"

#include <spdlog/spdlog.h>
#include <sys/resource.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <utility>

namespace mfot::service {

BackgroundQueue::BackgroundQueue(std::string name, std::size_t capacity, int nice_increment)
    : name_(std::move(name)), capacity_(capacity) {
  if (capacity < 1 || capacity > 1024) {
    throw std::invalid_argument("BackgroundQueue capacity must be in [1, 1024], got " + std::to_string(capacity));
  }
  if (nice_increment < 0 || nice_increment > 19) {
    throw std::invalid_argument("BackgroundQueue nice_increment must be in [0, 19], got " +
                                std::to_string(nice_increment));
  }
  thread_ = std::thread([this, nice_increment] { run(nice_increment); });
}

BackgroundQueue::~BackgroundQueue() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  thread_.join();
  if (failure_) {
    try {
      std::rethrow_exception(failure_);
    } catch (const std::exception& e) {
      spdlog::error("{}: {}", name_, e.what());
    } catch (...) {
      spdlog::error("{}: a job failed", name_);
    }
  }
}

void BackgroundQueue::rethrow_failure() {
  if (!failure_) return;
  std::exception_ptr failure = std::exchange(failure_, nullptr);
  std::rethrow_exception(failure);
}

void BackgroundQueue::push(std::function<void()> job) {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [&] { return jobs_.size() < capacity_ || failure_; });
  rethrow_failure();
  jobs_.push_back(std::move(job));
  changed_.notify_all();
}

void BackgroundQueue::finish() {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [&] { return (jobs_.empty() && !busy_) || failure_; });
  rethrow_failure();
}

void BackgroundQueue::run(int nice_increment) {
  if (nice_increment > 0) {
    errno = 0;
    const int nice = getpriority(PRIO_PROCESS, 0);  // 0: this thread on Linux
    if ((nice == -1 && errno != 0) || setpriority(PRIO_PROCESS, 0, nice + nice_increment) != 0) {
      spdlog::warn("{}: cannot lower the thread's priority ({})", name_, std::strerror(errno));
    }
  }
  std::unique_lock lock(mutex_);
  for (;;) {
    changed_.wait(lock, [&] { return stop_ || !jobs_.empty(); });
    if (jobs_.empty()) return;  // stopping with nothing left
    std::function<void()> job = std::move(jobs_.front());
    jobs_.pop_front();
    busy_ = true;
    lock.unlock();
    std::exception_ptr failure;
    try {
      job();
    } catch (...) {
      failure = std::current_exception();
    }
    lock.lock();
    busy_ = false;
    if (failure) {
      failure_ = failure;
      jobs_.clear();
    }
    changed_.notify_all();
  }
}

}  // namespace mfot::service
