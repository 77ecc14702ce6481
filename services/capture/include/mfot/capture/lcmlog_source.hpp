#pragma once
// The frames of a recorded lcm log (lcm-logger's file of a run): every MFOT_FRAME event in log
// order, published as recorded (SourceFrame::encoded), so replaying a log through a fresh process
// group in lockstep reproduces its poses and segmentation bit for bit. Undecodable events are
// skipped and counted; a file that is not an lcm log is refused when opened, and a truncated or
// corrupt event fails next() with the byte offset (service::LcmLogReader validates every header).

#include <cstdint>
#include <memory>
#include <string>

#include "mfot/capture/frame_source.hpp"
#include "mfot/service/lcm_log_reader.hpp"

namespace mfot::capture {

class LcmLogSource : public FrameSource {
 public:
  // Throws CaptureError naming the file when it cannot be opened or is not an LCM log.
  explicit LcmLogSource(std::string path);

  // Throws CaptureError naming the file and byte offset of a truncated or corrupt event.
  std::optional<SourceFrame> next() override;
  std::string name() const override { return "lcmlog:" + path_; }
  std::string kind() const override { return "lcmlog"; }
  bool rewind() override;

  // MFOT_FRAME events that did not decode, so far.
  std::int64_t undecodable() const { return undecodable_; }

 private:
  void open();

  std::string path_;
  std::unique_ptr<service::LcmLogReader> log_;
  std::int64_t index_ = 0;
  std::int64_t undecodable_ = 0;
};

}  // namespace mfot::capture
