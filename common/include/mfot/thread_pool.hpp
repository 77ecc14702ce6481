#pragma once
// A fixed set of worker threads that run the tasks of one call together with the calling thread,
// for per-frame work split into independent pieces (the preprocessing's rows, points and grid
// cells). Which thread runs a task is left to timing, so callers make each task's result
// independent of it (disjoint outputs, integer counts, no floating-point sums across tasks):
// the results are then the same for every thread count.

#include <condition_variable>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <type_traits>
#include <vector>

namespace mfot {

class ThreadPool {
 public:
  // threads: in [1, 64], the caller included; 1 starts no thread and runs every task inline.
  explicit ThreadPool(int threads);
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  int threads() const { return static_cast<int>(workers_.size()) + 1; }

  // Runs task(i) once for every i in [0, count) and returns when all are done. When tasks throw,
  // the exception of the lowest i is rethrown (the others are dropped). Not reentrant: one call
  // at a time, and a task must not call run() on the same pool.
  template <class Task>
  void run(std::size_t count, Task&& task) {
    using Callable = std::remove_reference_t<Task>;
    run_erased(
        count, [](void* callable, std::size_t i) { (*static_cast<Callable*>(callable))(i); },
        const_cast<void*>(static_cast<const void*>(&task)));
  }

 private:
  // A task without std::function, so a call allocates nothing.
  using Invoke = void (*)(void* callable, std::size_t i);
  void run_erased(std::size_t count, Invoke invoke, void* callable);
  void work_loop();
  void take_tasks();

  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::condition_variable done_;
  // The current call, guarded by mutex_ (tasks are handed out under it too: a task is far longer
  // than taking the lock).
  Invoke invoke_ = nullptr;
  void* callable_ = nullptr;
  std::size_t count_ = 0;
  std::size_t next_ = 0;
  std::size_t unfinished_ = 0;  // tasks not finished yet
  std::size_t generation_ = 0;
  std::size_t error_index_ = 0;
  std::exception_ptr error_;
  bool stop_ = false;
};

}  // namespace mfot
