#pragma once
// Settings of the capture service: section `capture` of the config file, overridden by the
// command line (configs/default.yaml documents every key and holds its default), and the source
// factory.

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "mfot/capture/frame_source.hpp"
#include "mfot/capture/pacing.hpp"
#include "mfot/service/config.hpp"
#include "mfot/service/frame_codec.hpp"

namespace mfot::capture {

struct CaptureSettings {
  std::string source = "sim";  // sim | tum | pcd | oni | openni2 | lcmlog
  RateMode rate = RateMode::kRealtime;
  double speed = 1.0;                                     // real-time playback factor, (0, 100]
  double lockstep_timeout_s = 5.0;                        // wait for MFOT_POSES before warning and moving on, (0, 3600]
  int lockstep_window = service::kDefaultLockstepWindow;  // frames without poses yet, [1, kMaxLockstepWindow]
  std::int64_t max_frames = 0;                            // frames to publish, 0 = unlimited
  std::int64_t start_frame = 0;                           // first source frame
  bool loop = false;                                      // restart a finite source at its end
  std::string groundtruth_dir;                            // "" = do not write ground truth
  service::EncodeOptions encoding{service::DepthEncoding::kRvl, service::ColorEncoding::kJpeg, 90, 1};

  // sim
  std::string scenario = "stack";  // mfot::sim::scenario_names()
  std::uint64_t seed = 1;
  int sim_frames = 0;     // 0 = the scenario's own length
  bool sim_noise = true;  // Kinect-like sensor noise
  int sim_objects = 3;    // random scenario: objects on the table [1, 16]
  // tum and pcd
  std::string tum_folder;
  double pcd_fps = 30.0;                       // pcd: the files carry no time
  unsigned long pcd_background_label_max = 0;  // pcd: labels up to this are background in the ground truth
  double depth_scale = 5000.0;                 // depth PNG units per metre
  double max_time_difference_s = 0.02;         // rgb/depth association tolerance
  std::array<float, 4> tum_intrinsics{service::kTumDefaultFx, service::kTumDefaultFy, service::kTumDefaultCx,
                                      service::kTumDefaultCy};  // fx fy cx cy of a folder without intrinsics.txt
  // lcmlog: the MFOT_FRAME events of a recorded run, as recorded (replay)
  std::string log_file;
  // oni
  std::string oni_file;
  // openni2
  std::string device_uri;  // "" = first device found
  double reopen_max_backoff_s = 10.0;

  // Throws service::ConfigError naming the setting.
  void validate() const;
};

// Reads every key of the section (a config laid over configs/default.yaml; unknown keys are
// errors); validate() after applying command-line overrides.
CaptureSettings load_capture_settings(service::ConfigSection section);

// Builds the configured source; throws CaptureError (e.g. missing folder, no camera, OpenNI2
// not built in) with a message for the user. stop_requested is polled by blocking sources.
std::unique_ptr<FrameSource> make_source(const CaptureSettings& settings, std::function<bool()> stop_requested);

bool openni2_available();

}  // namespace mfot::capture
