#include "mfot/capture/source_reader.hpp"

#include <spdlog/spdlog.h>
#include <sys/resource.h>

#include <cerrno>
#include <condition_variable>
#include <cstring>
#include <mutex>

#include "mfot/service/lcm_util.hpp"

namespace mfot::capture {

namespace {
// Linux niceness is per thread: the reader runs this much nicer than the service.
constexpr int kReaderNiceIncrement = 5;

void lower_thread_priority(const std::string& name) {
  errno = 0;
  const int nice = getpriority(PRIO_PROCESS, 0);  // 0: this thread on Linux
  if ((nice == -1 && errno != 0) || setpriority(PRIO_PROCESS, 0, nice + kReaderNiceIncrement) != 0) {
    spdlog::warn("{}: cannot lower the reader thread's priority ({}); it competes with the pipeline", name,
                 std::strerror(errno));
  }
}
}  // namespace

struct SourceReader::State {
  std::unique_ptr<FrameSource> source;
  std::string name;
  std::mutex mutex;
  std::condition_variable changed;
  std::optional<Result> result;  // handed to the publisher, at most one at a time
  bool stop = false;
  bool done = false;
};

SourceReader::SourceReader(std::unique_ptr<FrameSource> source, std::int64_t start_frame, bool loop,
                           service::EncodeOptions encoding)
    : state_(std::make_shared<State>()) {
  state_->source = std::move(source);
  // The thread shares the state, so a thread still blocked in the source when the service exits
  // never touches freed memory.
  thread_ =
      std::thread([state = state_, start_frame, loop, encoding] { read_all(*state, start_frame, loop, encoding); });
}

SourceReader::~SourceReader() {
  std::unique_lock lock(state_->mutex);
  state_->stop = true;
  state_->changed.notify_all();
  if (state_->changed.wait_for(lock, std::chrono::seconds(2), [&] { return state_->done; })) {
    lock.unlock();
    thread_.join();
  } else {
    spdlog::warn("{} is still blocked in a read; exiting without it", state_->name);
    thread_.detach();
  }
}

std::optional<SourceReader::Result> SourceReader::next(Clock::time_point deadline) {
  std::unique_lock lock(state_->mutex);
  if (!state_->changed.wait_until(lock, deadline, [&] { return state_->result.has_value(); })) return std::nullopt;
  Result result = std::move(*state_->result);
  state_->result.reset();
  state_->changed.notify_all();
  return result;
}

void SourceReader::read_all(State& state, std::int64_t start_frame, bool loop, const service::EncodeOptions& encoding) {
  FrameSource& source = *state.source;
  const std::string name = source.name();
  lower_thread_priority(name);
  {
    std::lock_guard lock(state.mutex);
    state.name = name;
  }
  const auto hand_over = [&state](Result result) {
    std::unique_lock lock(state.mutex);
    state.changed.wait(lock, [&] { return state.stop || !state.result.has_value(); });
    if (state.stop) return false;
    state.result = std::move(result);
    state.changed.notify_all();
    return true;
  };
  try {
    if (start_frame > 0) source.seek(start_frame);
    bool rewound = false;
    for (;;) {
      const auto start = Clock::now();
      std::optional<SourceFrame> item = source.next();
      if (!item) {
        if (service::stop_requested()) break;
        if (loop && !rewound && source.rewind()) {
          if (start_frame > 0) source.seek(start_frame);
          rewound = true;
          continue;
        }
        hand_over(Ended{});
        break;
      }
      frame_t message =
          item->encoded ? std::move(*item->encoded) : service::encode_frame(item->frame, encoding, 0, name, 0);
      item->encoded.reset();
      const double read_ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
      if (!hand_over(Frame{std::move(*item), std::move(message), rewound, read_ms})) break;
      rewound = false;
    }
  } catch (const std::exception& e) {
    hand_over(Failed{e.what()});
  }
  std::lock_guard lock(state.mutex);
  state.done = true;
  state.changed.notify_all();
}

}  // namespace mfot::capture
