#pragma once
// Runs jobs in order on one thread of lower CPU priority, off the caller's latency-critical path
// (the merger's label images and fitting distances after the poses are published). At most
// `capacity` jobs wait: push() blocks beyond that, so a writer that falls behind slows the caller
// instead of growing memory. A job's exception is kept and rethrown by the next push() or by
// finish(); later jobs are dropped after it. The destructor finishes the queued jobs.

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

namespace mfot::service {

class BackgroundQueue {
 public:
  // capacity in [1, 1024]; nice_increment in [0, 19] (Linux niceness is per thread), applied by
  // the worker thread to itself. Throws std::invalid_argument naming a value out of range.
  BackgroundQueue(std::string name, std::size_t capacity, int nice_increment);
  BackgroundQueue(const BackgroundQueue&) = delete;
  BackgroundQueue& operator=(const BackgroundQueue&) = delete;
  ~BackgroundQueue();

  void push(std::function<void()> job);
  // Returns when every pushed job has run; rethrows a job's exception.
  void finish();

 private:
  void run(int nice_increment);
  void rethrow_failure();  // with mutex_ held

  std::string name_;
  std::size_t capacity_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::function<void()>> jobs_;
  bool busy_ = false;  // a job is running
  bool stop_ = false;
  std::exception_ptr failure_;
  std::thread thread_;
};

}  // namespace mfot::service
