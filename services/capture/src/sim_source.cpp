#include "mfot/capture/sim_source.hpp"

#include <cmath>

namespace mfot::capture {

SourceFrame to_source_frame(const sim::RenderedFrame& rendered) {
  SourceFrame out;
  out.index = rendered.index;
  service::Frame& frame = out.frame;
  frame.capture_utime = std::llround(rendered.time_s * 1e6);
  frame.width = rendered.intrinsics.width;
  frame.height = rendered.intrinsics.height;
  frame.fx = rendered.intrinsics.fx;
  frame.fy = rendered.intrinsics.fy;
  frame.cx = rendered.intrinsics.cx;
  frame.cy = rendered.intrinsics.cy;
  frame.depth_mm = rendered.depth_mm;
  frame.color = rendered.color;

  service::GroundTruthFrame truth;
  truth.frame = rendered.index;
  truth.utime = frame.capture_utime;
  for (const auto& pose : rendered.poses)
    truth.objects.push_back({pose.id, pose.is_hand, pose.pose, pose.symmetry_axis});
  // Ground truth of the measured pixels only: a pixel without depth has no 3-D point any
  // tracker could label, so scoring it would measure the sensor model, not the tracker.
  truth.labels = service::Image16{frame.width, frame.height, rendered.labels};
  for (std::size_t i = 0; i < truth.labels.pixels.size(); ++i) {
    if (frame.depth_mm[i] == 0) truth.labels.pixels[i] = 0;
  }
  out.truth = std::move(truth);
  return out;
}

SimSource::SimSource(const sim::SimulatorOptions& options) : simulator_(options) {}

std::optional<SourceFrame> SimSource::next() {
  if (next_index_ >= simulator_.num_frames()) return std::nullopt;
  return to_source_frame(simulator_.render(next_index_++));
}

bool SimSource::rewind() {
  next_index_ = 0;
  return true;
}

void SimSource::seek(std::int64_t index) {
  if (index < 0 || index >= simulator_.num_frames()) {
    throw CaptureError(name() + ": start frame " + std::to_string(index) + " is outside [0, " +
                       std::to_string(simulator_.num_frames()) + ")");
  }
  next_index_ = static_cast<int>(index);
}

}  // namespace mfot::capture
