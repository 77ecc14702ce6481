#pragma once
// Reads a FrameSource and encodes its images on its own thread, one frame ahead of the publisher
// (in lockstep the next frame is ready to go the moment the poses arrive). Seeking to the start
// frame and rewinding for --loop happen there too, so every source call stays on one thread. The
// thread runs nicer than its caller: reading ahead (for the simulator: rendering, ~20 ms of CPU a
// frame) must not take the CPU from the pipeline working on the frame already published.

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <variant>

#include "mfot/capture/frame_source.hpp"
#include "mfot/service/frame_codec.hpp"

namespace mfot::capture {

class SourceReader {
 public:
  using Clock = std::chrono::steady_clock;

  struct Frame {
    SourceFrame item;
    frame_t message;       // the encoded images (as recorded, for a log); the publisher sets seq, utime, capture_utime
    bool rewound = false;  // the first frame after a --loop rewind
    double read_ms = 0.0;  // reading and encoding
  };
  struct Ended {};
  struct Failed {
    std::string error;
  };
  using Result = std::variant<Frame, Ended, Failed>;

  // Starts reading at once: seeks to start_frame, and with `loop` rewinds once at each end.
  SourceReader(std::unique_ptr<FrameSource> source, std::int64_t start_frame, bool loop,
               service::EncodeOptions encoding);
  SourceReader(const SourceReader&) = delete;
  SourceReader& operator=(const SourceReader&) = delete;
  // Stops the thread; one still blocked in the source after 2 s is left behind (it owns its state).
  ~SourceReader();

  // The next result, or nullopt when none came before `deadline`.
  std::optional<Result> next(Clock::time_point deadline);

 private:
  struct State;
  static void read_all(State& state, std::int64_t start_frame, bool loop, const service::EncodeOptions& encoding);

  std::shared_ptr<State> state_;
  std::thread thread_;
};

}  // namespace mfot::capture
