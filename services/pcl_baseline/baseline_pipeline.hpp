#pragma once
// The PCL baseline's pipeline (mfot-pcl-baseline), in one process like mfot-inprocess: the frame's
// wire encoding, our Preprocessor, objects from the first frame's clusters exactly as mfot creates
// them (ObjectManager's first frame), then one PCL KLDAdaptiveParticleFilterOMPTracker per object on
// the preprocessed scene; scene points are labelled with the object of the nearest tracked model
// point (our Segmenter, merger.tau). PCL's tracker has a fixed reference and never adds objects: no
// model update and no new objects after the first frame.

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "mfot/object_manager.hpp"
#include "mfot/preprocessing.hpp"
#include "mfot/segmentation.hpp"
#include "mfot/service/config.hpp"
#include "mfot/service/convert.hpp"
#include "mfot/service/frame_codec.hpp"
#include "pcl_object_tracker.hpp"

namespace mfot::service {

struct BaselineConfig {
  pcl_baseline::PclTrackerSettings tracker;
  unsigned seed = 1;
};

// Section pcl_baseline of the baseline's own config file laid over configs/default.yaml (strict like
// the services' configs).
BaselineConfig load_baseline_config(const std::string& path);

struct BaselineOptions {
  EncodeOptions encoding;
  PreprocessorOptions preprocess;
  ObjectManagerOptions manager;
  pcl_baseline::PclTrackerSettings tracker;
};

class BaselinePipeline {
 public:
  explicit BaselinePipeline(const BaselineOptions& options);
  BaselinePipeline(const BaselinePipeline&) = delete;
  BaselinePipeline& operator=(const BaselinePipeline&) = delete;

  // One frame; the scene and labels are valid until the next call.
  void process(const Frame& frame, std::int64_t seq, const std::string& source_name);

  const frame_t& message() const { return message_; }  // the frame as it travelled
  const Scene& scene() const { return scene_; }
  const std::vector<std::int32_t>& labels() const { return *labels_; }
  // Every object with its pose and model (confidence 1: PCL's tracker reports none in [0, 1]).
  const std::map<std::int32_t, ManagedObject>& objects() const { return objects_; }
  double track_ms() const { return track_ms_; }
  int particles_used() const { return particles_; }

 private:
  BaselineOptions options_;
  Preprocessor preprocessor_;
  ObjectManager first_frame_objects_;
  Segmenter segmenter_;
  std::map<std::int32_t, std::unique_ptr<pcl_baseline::PclObjectTracker>> trackers_;
  std::map<std::int32_t, ManagedObject> objects_;
  frame_t message_;
  Scene scene_;
  const std::vector<std::int32_t>* labels_ = nullptr;
  std::vector<float> scene_xyz_;
  std::vector<std::uint8_t> scene_rgb_;
  pcl_baseline::PclScene pcl_scene_;
  std::vector<SegmentationObject> seg_objects_;
  SegmentationResult segmentation_;
  double track_ms_ = 0.0;
  int particles_ = 0;
};

}  // namespace mfot::service
