#pragma once
// The capture service's input: a source of registered RGB-D frames (simulator, TUM folder,
// OpenNI2 recording or camera) behind one interface, usable without LCM.

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>

#include "mfot/service/frame_codec.hpp"
#include "mfot/service/tum_dataset.hpp"

namespace mfot::capture {

struct CaptureError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct SourceFrame {
  service::Frame frame;
  std::int64_t index = 0;  // position in the source (frame number of finite sources)
  // Ground truth when the source knows it (simulator; TUM folders with groundtruth/); its
  // `frame` field is the source index.
  std::optional<service::GroundTruthFrame> truth;
  // The frame as it travelled when the source recorded it encoded (an lcm log): published as is,
  // so a replay is bit for bit the recording; `frame` then carries its capture time only.
  std::optional<frame_t> encoded;
};

class FrameSource {
 public:
  FrameSource() = default;
  FrameSource(const FrameSource&) = delete;
  FrameSource& operator=(const FrameSource&) = delete;
  virtual ~FrameSource() = default;

  // The next frame; nullopt when a finite source has ended (or a live one was asked to stop).
  virtual std::optional<SourceFrame> next() = 0;
  // Published in frame_t.source, e.g. "sim:stack", "tum:/data/fr1_desk".
  virtual std::string name() const = 0;
  // What the scene is made of as a small YAML document (the simulator's SceneSummary), written
  // beside the ground truth as scene.yaml; empty for sources that do not know.
  virtual std::string scene_yaml() const { return {}; }
  // Status backend: "sim", "tum", "oni" or "openni2".
  virtual std::string kind() const = 0;
  // A live camera paces itself; real-time pacing by timestamps does not apply.
  virtual bool live() const { return false; }
  // Back to the first frame (for --loop); false when the source cannot.
  virtual bool rewind() { return false; }
  // Called at the start or right after rewind(): the next frame will be frame `index` (for
  // --start-frame). The default reads and drops frames; throws CaptureError when the source
  // ends first.
  virtual void seek(std::int64_t index);
};

}  // namespace mfot::capture
