#include "mfot/capture/capture_settings.hpp"

#include "mfot/capture/lcmlog_source.hpp"
#include "mfot/capture/pcd_source.hpp"
#include "mfot/capture/sim_source.hpp"
#include "mfot/capture/tum_source.hpp"
#include "mfot/service/options.hpp"
#ifdef MFOT_HAVE_OPENNI2
#include "mfot/capture/openni_source.hpp"
#endif

#include <algorithm>
#include <cmath>
#include <limits>

namespace mfot::capture {

using service::ConfigError;
using service::read_choice;
using service::read_list;
using service::read_option;

void CaptureSettings::validate() const {
  const std::vector<std::string> sources = {"sim", "tum", "pcd", "oni", "openni2", "lcmlog"};
  if (std::find(sources.begin(), sources.end(), source) == sources.end()) {
    throw ConfigError("capture.source: '" + source + "' is not one of sim|tum|pcd|oni|openni2|lcmlog");
  }
  if (!(std::isfinite(speed) && speed > 0.0 && speed <= 100.0)) {
    throw ConfigError("capture.speed: " + std::to_string(speed) + " is out of range (0, 100]");
  }
  if (!(std::isfinite(lockstep_timeout_s) && lockstep_timeout_s > 0.0 && lockstep_timeout_s <= 3600.0)) {
    throw ConfigError("capture.lockstep_timeout_s: " + std::to_string(lockstep_timeout_s) +
                      " is out of range (0, 3600]");
  }
  if (lockstep_window < 1 || lockstep_window > service::kMaxLockstepWindow) {
    throw ConfigError("capture.lockstep_window: " + std::to_string(lockstep_window) + " is out of range [1, " +
                      std::to_string(service::kMaxLockstepWindow) + "]");
  }
  if (max_frames < 0) throw ConfigError("capture.max_frames: must be >= 0 (0 = unlimited)");
  if (start_frame < 0) throw ConfigError("capture.start_frame: must be >= 0");
  try {
    encoding.validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(std::string("capture encoding: ") + e.what());
  }
  const auto names = sim::scenario_names();
  if (std::find(names.begin(), names.end(), scenario) == names.end()) {
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "" : "|") + n;
    throw ConfigError("capture.scenario: '" + scenario + "' is not one of " + list);
  }
  if (sim_frames < 0 || sim_frames > 1000000) throw ConfigError("capture.sim_frames: out of range [0, 1000000]");
  if (sim_objects < 1 || sim_objects > 16) throw ConfigError("capture.sim_objects: out of range [1, 16]");
  if ((source == "tum" || source == "pcd") && tum_folder.empty()) {
    throw ConfigError("capture.folder: required for source " + source + " (--folder)");
  }
  if (!(std::isfinite(pcd_fps) && pcd_fps > 0.0 && pcd_fps <= 1000.0)) {
    throw ConfigError("capture.pcd_fps: out of range (0, 1000]");
  }
  if (!(std::isfinite(depth_scale) && depth_scale > 0.0)) throw ConfigError("capture.depth_scale: must be > 0");
  if (!(tum_intrinsics[0] > 0.f && tum_intrinsics[1] > 0.f && std::isfinite(tum_intrinsics[2]) &&
        std::isfinite(tum_intrinsics[3]))) {
    throw ConfigError("capture.tum_intrinsics: fx and fy must be > 0 and cx, cy finite");
  }
  if (!(std::isfinite(max_time_difference_s) && max_time_difference_s > 0.0)) {
    throw ConfigError("capture.max_time_difference_s: must be > 0");
  }
  if (source == "lcmlog" && log_file.empty()) throw ConfigError("capture.log_file: required for source lcmlog (--log)");
  if (source == "oni" && oni_file.empty()) throw ConfigError("capture.oni_file: required for source oni (--oni)");
  if (!(std::isfinite(reopen_max_backoff_s) && reopen_max_backoff_s >= 0.5 && reopen_max_backoff_s <= 600.0)) {
    throw ConfigError("capture.reopen_max_backoff_s: out of range [0.5, 600]");
  }
}

CaptureSettings load_capture_settings(service::ConfigSection section) {
  CaptureSettings s;
  s.source = read_choice(section, "source");
  s.rate = parse_rate_mode(read_choice(section, "rate"));
  s.speed = read_option<double>(section, "speed");
  s.lockstep_timeout_s = read_option<double>(section, "lockstep_timeout_s");
  s.lockstep_window = read_option<int>(section, "lockstep_window");
  s.max_frames = read_option<long>(section, "max_frames");
  s.start_frame = read_option<long>(section, "start_frame");
  s.loop = read_option<bool>(section, "loop");
  s.groundtruth_dir = read_option<std::string>(section, "groundtruth_dir");

  s.encoding.depth = service::parse_depth_encoding(read_choice(section, "depth_encoding"));
  s.encoding.color = service::parse_color_encoding(read_choice(section, "color_encoding"));
  s.encoding.jpeg_quality = read_option<int>(section, "jpeg_quality");
  s.encoding.zlib_level = read_option<int>(section, "zlib_level");

  s.scenario = read_choice(section, "scenario");
  s.seed = read_option<unsigned long>(section, "seed");
  s.sim_frames = read_option<int>(section, "sim_frames");
  s.sim_noise = read_option<bool>(section, "sim_noise");
  s.sim_objects = read_option<int>(section, "sim_objects");

  s.tum_folder = read_option<std::string>(section, "folder");
  s.depth_scale = read_option<double>(section, "depth_scale");
  s.max_time_difference_s = read_option<double>(section, "max_time_difference_s");
  const auto intrinsics = read_list(section, "tum_intrinsics");
  for (std::size_t i = 0; i < 4; ++i) s.tum_intrinsics[i] = static_cast<float>(intrinsics[i]);

  s.pcd_fps = read_option<double>(section, "pcd_fps");
  s.pcd_background_label_max = read_option<unsigned long>(section, "pcd_background_label_max");
  s.log_file = read_option<std::string>(section, "log_file");
  s.oni_file = read_option<std::string>(section, "oni_file");
  s.device_uri = read_option<std::string>(section, "device_uri");
  s.reopen_max_backoff_s = read_option<double>(section, "reopen_max_backoff_s");

  section.finish();
  return s;
}

bool openni2_available() {
#ifdef MFOT_HAVE_OPENNI2
  return true;
#else
  return false;
#endif
}

std::unique_ptr<FrameSource> make_source(const CaptureSettings& settings, std::function<bool()> stop_requested) {
  settings.validate();
  if (settings.source == "sim") {
    sim::SimulatorOptions options;
    options.scenario.name = settings.scenario;
    options.scenario.seed = settings.seed;
    options.scenario.num_frames = settings.sim_frames;
    options.sensor.noise = settings.sim_noise;
    options.scenario.num_objects = settings.sim_objects;
    try {
      return std::make_unique<SimSource>(options);
    } catch (const std::invalid_argument& e) {
      throw CaptureError(std::string("simulator: ") + e.what());
    }
  }
  if (settings.source == "tum") {
    service::TumReaderOptions options;
    options.folder = settings.tum_folder;
    options.depth_scale = settings.depth_scale;
    options.max_time_difference_s = settings.max_time_difference_s;
    options.intrinsics = settings.tum_intrinsics;
    try {
      return std::make_unique<TumSource>(options);
    } catch (const service::DatasetError& e) {
      throw CaptureError(e.what());
    }
  }
  if (settings.source == "lcmlog") return std::make_unique<LcmLogSource>(settings.log_file);
  if (settings.source == "pcd") {
    return std::make_unique<PcdFolderSource>(settings.tum_folder, 1.0 / settings.pcd_fps,
                                             static_cast<std::uint32_t>(settings.pcd_background_label_max));
  }
#ifdef MFOT_HAVE_OPENNI2
  OpenNiOptions options;
  options.file = settings.source == "oni";
  options.uri = options.file ? settings.oni_file : settings.device_uri;
  options.reopen_max_backoff_s = settings.reopen_max_backoff_s;
  options.reopen_initial_backoff_s = std::min(options.reopen_initial_backoff_s, options.reopen_max_backoff_s);
  options.stop_requested = std::move(stop_requested);
  return std::make_unique<OpenNiSource>(options);
#else
  (void)stop_requested;
  throw CaptureError("source '" + settings.source +
                     "' needs OpenNI2, but this build has none (configure with -DMFOT_OPENNI2=ON and libopenni2-dev)");
#endif
}

}  // namespace mfot::capture
