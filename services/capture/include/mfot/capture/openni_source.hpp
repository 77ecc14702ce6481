#pragma once
// OpenNI2 source: a live camera (PrimeSense / Kinect / Xtion class) with depth registered to
// colour at 640x480 and 30 Hz, or an .oni recording opened as a device. Recordings play in
// OpenNI's manual mode (one frame per read), so the capture service paces them by their
// timestamps (playback speed is the service's --speed). A camera that stops delivering frames is
// closed and reopened with exponential back-off, and the service says so in its log.
// Built only with MFOT_OPENNI2 (make_source reports otherwise).

#include <functional>
#include <memory>

#include "mfot/capture/frame_source.hpp"

namespace mfot::capture {

struct OpenNiOptions {
  std::string uri;                        // device URI ("" = first device found) or, with file, the .oni path
  bool file = false;                      // uri is an .oni recording
  int width = 640;                        // requested live video mode, [1, 4096]
  int height = 480;                       // [1, 4096]
  int fps = 30;                           // [1, 120]
  int read_timeout_ms = 2000;             // a live camera silent this long is reopened, [100, 60000]
  double reopen_initial_backoff_s = 0.5;  // (0, reopen_max_backoff_s]
  double reopen_max_backoff_s = 10.0;     // (0, 600]
  std::function<bool()> stop_requested;   // polled while waiting; may be empty

  void validate() const;  // std::invalid_argument naming the field
};

class OpenNiSource final : public FrameSource {
 public:
  // Opens the device or recording; throws CaptureError when none is found or it cannot be
  // opened (the message says which and why).
  explicit OpenNiSource(OpenNiOptions options);
  ~OpenNiSource() override;

  std::optional<SourceFrame> next() override;
  std::string name() const override;
  std::string kind() const override { return options_.file ? "oni" : "openni2"; }
  bool live() const override { return !options_.file; }
  bool rewind() override;
  void seek(std::int64_t index) override;

 private:
  struct Device;
  void open();  // throws CaptureError
  // One registered pair, or nullopt with `failure` set.
  std::optional<SourceFrame> read_pair(std::string& failure);

  OpenNiOptions options_;
  std::unique_ptr<Device> device_;
  std::string uri_;  // of the device last opened
  std::int64_t next_index_ = 0;
};

}  // namespace mfot::capture
