#pragma once
// Live simulator source: renders the frames of a scripted scenario (mfot::sim::Simulator) one by
// one, with per-frame ground truth (poses and labels). Timestamps are the scenario time, so
// runs are reproducible.

#include "mfot/capture/frame_source.hpp"
#include "mfot/sim/simulator.hpp"

namespace mfot::capture {

// Converts one rendered frame to the capture frame and its ground truth (frame index = index).
SourceFrame to_source_frame(const sim::RenderedFrame& rendered);

class SimSource final : public FrameSource {
 public:
  explicit SimSource(const sim::SimulatorOptions& options);

  std::optional<SourceFrame> next() override;
  // "sim:<scenario>"; a procedural scene adds its seed, motion class and moved shapes.
  std::string name() const override { return simulator_.summary().source_name(); }
  std::string scene_yaml() const override { return simulator_.summary().yaml(); }
  std::string kind() const override { return "sim"; }
  bool rewind() override;
  void seek(std::int64_t index) override;  // no rendering of the skipped frames

  const sim::Simulator& simulator() const { return simulator_; }

 private:
  sim::Simulator simulator_;
  int next_index_ = 0;
};

}  // namespace mfot::capture
