#pragma once
// The whole pipeline in one process with direct calls, no LCM, the same stages and config
// sections as the services: a frame's wire encoding (as the capture sends it, possibly lossy) ->
// Preprocessor -> one ObjectTracker per object (as tracker workers run them) -> ObjectManager (as
// the merger runs it). It measures the method without the transport and serves tests.
// Steps of process(): encode and decode the frame; preprocess it into the scene; track every
// object on it; segment, update models, create and retire objects; give each new object a
// tracker and each tracker its object's model (a new grid only for a new model version).

#include <cstdint>
#include <map>
#include <memory>
#include <string>

#include "mfot/object_manager.hpp"
#include "mfot/preprocessing.hpp"
#include "mfot/service/convert.hpp"
#include "mfot/service/frame_codec.hpp"
#include "mfot/service/object_tracker.hpp"
#include "mfot/service/pipeline_config.hpp"

namespace mfot::service {

struct InprocessOptions {
  EncodeOptions encoding;  // capture's depth and colour encodings
  PreprocessorOptions preprocess;
  TrackerConfig tracker;
  ObjectManagerOptions manager;
  int merger_threads = 1;  // MergerCoreOptions::threads
};

// Milliseconds of one frame's stages.
struct StageTimes {
  double codec_ms = 0.0;
  double preprocess_ms = 0.0;
  double track_ms = 0.0;
  double merge_ms = 0.0;
};

struct InprocessFrame {
  frame_t message;  // as it travelled
  Scene scene;
  StageTimes times;
};

class InprocessPipeline {
 public:
  explicit InprocessPipeline(const InprocessOptions& options);
  InprocessPipeline(const InprocessPipeline&) = delete;
  InprocessPipeline& operator=(const InprocessPipeline&) = delete;

  // One frame of `source_name`, numbered `seq`; the returned frame is valid until the next call.
  const InprocessFrame& process(const Frame& frame, std::int64_t seq, const std::string& source_name);

  const ObjectManager& manager() const { return manager_; }
  const ObjectManagerFrame& result() const { return manager_.last_frame(); }
  const std::map<std::int32_t, std::unique_ptr<ObjectTracker>>& trackers() const { return trackers_; }

 private:
  InprocessOptions options_;
  Preprocessor preprocessor_;
  ObjectManager manager_;
  std::map<std::int32_t, std::unique_ptr<ObjectTracker>> trackers_;
  float claimed_margin_ = 0.f;            // as the merger's (MergerConfig::claimed_margin)
  std::vector<Eigen::Vector3f> claimed_;  // what the other objects claim near the object tracked
  InprocessFrame frame_;
};

}  // namespace mfot::service
