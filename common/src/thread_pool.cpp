#include "mfot/thread_pool.hpp"

#include <stdexcept>
#include <string>
#include <utility>

namespace mfot {

ThreadPool::ThreadPool(int threads) {
  if (threads < 1 || threads > 64) {
    throw std::invalid_argument("ThreadPool threads must be in [1, 64], got " + std::to_string(threads));
  }
  workers_.reserve(static_cast<std::size_t>(threads - 1));
  for (int t = 1; t < threads; ++t) workers_.emplace_back([this] { work_loop(); });
}

ThreadPool::~ThreadPool() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  for (std::thread& worker : workers_) worker.join();
}

void ThreadPool::run_erased(std::size_t count, Invoke invoke, void* callable) {
  if (count == 0) return;
  if (workers_.empty() || count == 1) {
    for (std::size_t i = 0; i < count; ++i) invoke(callable, i);  // in order: the first exception is the lowest i
    return;
  }
  {
    std::lock_guard lock(mutex_);
    invoke_ = invoke;
    callable_ = callable;
    count_ = count;
    next_ = 0;
    unfinished_ = count;
    error_ = nullptr;
    ++generation_;
  }
  wake_.notify_all();
  // A worker that is slow to wake (its core busy elsewhere) finds nothing left: the caller waits
  // only for tasks that were started.
  take_tasks();
  std::unique_lock lock(mutex_);
  done_.wait(lock, [this] { return unfinished_ == 0; });
  invoke_ = nullptr;
  callable_ = nullptr;
  if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
}

void ThreadPool::work_loop() {
  std::size_t seen = 0;
  for (;;) {
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
      if (stop_) return;
      seen = generation_;
    }
    take_tasks();
  }
}

void ThreadPool::take_tasks() {
  for (;;) {
    std::size_t i = 0;
    Invoke invoke = nullptr;
    void* callable = nullptr;
    {
      std::lock_guard lock(mutex_);
      if (next_ >= count_) return;
      i = next_++;
      invoke = invoke_;
      callable = callable_;
    }
    std::exception_ptr error;
    try {
      invoke(callable, i);
    } catch (...) {
      error = std::current_exception();
    }
    std::lock_guard lock(mutex_);
    if (error && (!error_ || i < error_index_)) {
      error_ = error;
      error_index_ = i;
    }
    if (--unfinished_ == 0) done_.notify_one();
  }
}

}  // namespace mfot
