#pragma once
// The capture service's loop over LCM: publishes the frames of a source (read ahead by a
// SourceReader) on MFOT_FRAME, paced in real time by the source timestamps (RealtimeSchedule),
// as fast as possible, or in lockstep with the pipeline (LockstepGate over MFOT_POSES); writes
// the source's ground truth; reports on MFOT_STATUS, also while the source stalls, and says why
// it ends before it returns.

#include <lcm/lcm-cpp.hpp>
#include <memory>

#include "mfot/capture/capture_settings.hpp"
#include "mfot/capture/frame_source.hpp"

namespace mfot::capture {

// Runs until the source ends (0), fails (1) or a stop is requested (0); the exit code.
int run_capture_service(lcm::LCM& lcm, CaptureSettings settings, std::unique_ptr<FrameSource> source);

// Bytes per frame and codec time of every encoding over the first `count` frames of the source,
// printed to stdout (no LCM); the exit code.
int measure_encodings(FrameSource& source, const service::EncodeOptions& base, int count);

}  // namespace mfot::capture
