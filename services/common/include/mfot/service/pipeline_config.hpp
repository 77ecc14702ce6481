#pragma once
// The config sections of the pipeline's stages (`preprocess`, `tracker`, `merger`), read strictly
// (unknown keys, wrong types and out-of-range values throw ConfigError naming the key and range).
// Shared by the services and the in-process runner, so both run exactly the same configuration.

#include "mfot/cuda/likelihood_factory.hpp"
#include "mfot/object_manager.hpp"
#include "mfot/particle_filter.hpp"
#include "mfot/preprocessing.hpp"
#include "mfot/service/config.hpp"
#include "mfot/service/tracker_scene_queue.hpp"
#include "mfot/tracking_step.hpp"

namespace mfot::service {

struct TrackerConfig {
  LikelihoodOptions likelihood;
  ParticleFilterOptions filter;
  TrackingStepOptions step;  // hypothesis data, occlusion hold and occluder removal
  int heartbeat_ms = 100;
  int merger_timeout_ms = 0;        // tracker.merger_timeout_ms (0 here: models from any merger, for tests)
  TrackerSceneQueueOptions scenes;  // queue_scenes, model_wait_ms
};

// The `preprocess` section: the core's options and the service's frame queue.
struct PreprocessConfig {
  PreprocessorOptions preprocessor;
  // Frames waiting for preprocessing, in order; beyond it the oldest is dropped. In lockstep up to
  // capture.lockstep_window wait (all of them can arrive before the first is processed); 1 =
  // always the newest (a live camera's lowest latency).
  int queue_frames = 8;
};

struct MergerConfig {
  ObjectManagerOptions manager;
  int estimate_timeout_ms = 500;
  int worker_timeout_ms = 1000;
  int expected_workers = 0;
  int startup_timeout_ms = 10000;
  int resume_listen_ms = 0;     // ObjectResumerOptions::listen (configs/default.yaml sets it)
  int resume_timeout_ms = 500;  // ObjectResumerOptions::report_timeout
  bool write_labels = true;
  bool fitting_distance = true;
  int threads = 1;  // merger.threads resolved (0: auto_threads())
  Pose world_from_camera;
  // MergerCoreOptions::claimed_margin: TrackingStepOptions::claimed_margin() of the tracker keys.
  float claimed_margin = 0.f;
};

// Every key is read from `root` (a config laid over the defaults, load_config_file) and documented
// in configs/default.yaml.
PreprocessConfig load_preprocess_config(const YAML::Node& root);
TrackerConfig load_tracker_config(const YAML::Node& root);
MergerConfig load_merger_config(const YAML::Node& root);

}  // namespace mfot::service
