// mfot-capture: the pipeline's input. Reads registered RGB-D frames from a source (the live
// simulator, a TUM RGB-D folder, a folder of organised PCD files, a recorded lcm log, an OpenNI2 .oni recording or a
// live OpenNI2 camera), encodes them (depth raw/zlib/RVL, colour raw/JPEG/PNG; a log's frames go out as recorded) and
// publishes frame_t on MFOT_FRAME, paced in real time by the source timestamps, as fast as possible, or in lockstep
// with the pipeline (at most capture.lockstep_window frames whose poses_t has not arrived on MFOT_POSES). Ground truth
// of the simulator (or of a rendered TUM folder) is written to --groundtruth-dir for offline scoring. Section `capture`
// of the config; the command line overrides it. The loop is run_capture_service (src/capture_service.cpp).
//
// --measure-encodings N prints bytes per frame of every encoding for the first N frames of the
// source and exits (no LCM).

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <string>

#include "mfot/capture/capture_service.hpp"
#include "mfot/capture/capture_settings.hpp"
#include "mfot/service/config.hpp"
#include "mfot/service/group_security.hpp"
#include "mfot/service/lcm_util.hpp"
#include "mfot/service/service_main.hpp"

int main(int argc, char** argv) {
  using namespace mfot::capture;
  using namespace mfot::service;
  CLI::App app{
      "mfot-capture: publish RGB-D frames (frame_t) on MFOT_FRAME from the simulator, a TUM folder, "
      "an .oni recording or an OpenNI2 camera"};
  std::string config_path;  // empty: the built-in defaults (configs/default.yaml)
  std::string lcm_url_arg;
  CaptureSettings cli;
  std::string rate, depth_encoding, color_encoding;
  int measure = 0;
  app.add_option("--config", config_path, "YAML config (section `capture`)");
  app.add_option("--lcm-url", lcm_url_arg, "LCM provider URL (default: $MFOT_LCM_URL, $LCM_DEFAULT_URL or udpm ttl=0)");
  auto* o_source = app.add_option("--source", cli.source, "sim | tum | pcd | oni | openni2 | lcmlog")
                       ->check(CLI::IsMember({"sim", "tum", "pcd", "oni", "openni2", "lcmlog"}));
  auto* o_scenario = app.add_option(
      "--scenario", cli.scenario,
      "sim scenario: stack | contact | rotate | apart | static | random | spin | tumble | slide | cross | procedural "
      "(procedural seeds: 1-999 development, 1000 and up acceptance only)");
  auto* o_seed = app.add_option("--seed", cli.seed, "sim: scenario and sensor-noise seed");
  auto* o_sim_frames =
      app.add_option("--sim-frames", cli.sim_frames, "sim: frames to render, 0 = the scenario's length");
  auto* o_folder =
      app.add_option("--folder", cli.tum_folder, "tum: the TUM RGB-D folder; pcd: the folder of organised PCD files");
  auto* o_depth_scale = app.add_option("--depth-scale", cli.depth_scale, "tum: depth PNG units per metre (TUM: 5000)");
  auto* o_log = app.add_option("--log", cli.log_file, "lcmlog: a recorded run's lcm log (its MFOT_FRAME events)");
  auto* o_oni = app.add_option("--oni", cli.oni_file, "oni: the .oni recording");
  auto* o_uri = app.add_option("--device-uri", cli.device_uri, "openni2: device URI (default: first device)");
  auto* o_rate = app.add_option("--rate", rate, "realtime | fast | lockstep")
                     ->check(CLI::IsMember({"realtime", "fast", "lockstep"}));
  auto* o_speed = app.add_option("--speed", cli.speed, "realtime playback speed factor (0, 100]");
  auto* o_timeout = app.add_option("--lockstep-timeout", cli.lockstep_timeout_s,
                                   "lockstep: seconds to wait for the poses of a frame before warning and moving on");
  auto* o_window =
      app.add_option("--lockstep-window", cli.lockstep_window, "lockstep: frames in flight without poses [1, 8]");
  auto* o_max = app.add_option("--max-frames", cli.max_frames, "frames to publish, 0 = unlimited");
  auto* o_start = app.add_option("--start-frame", cli.start_frame, "first source frame");
  auto* o_loop = app.add_flag("--loop", cli.loop, "restart a finite source at its end");
  auto* o_truth = app.add_option("--groundtruth-dir", cli.groundtruth_dir,
                                 "write ground truth (poses.csv, labels/) of sources that have it to this folder");
  auto* o_depth = app.add_option("--depth-encoding", depth_encoding, "raw | zlib | rvl")
                      ->check(CLI::IsMember({"raw", "zlib", "rvl"}));
  auto* o_color = app.add_option("--color-encoding", color_encoding, "raw | jpeg | png")
                      ->check(CLI::IsMember({"raw", "jpeg", "png"}));
  auto* o_quality = app.add_option("--jpeg-quality", cli.encoding.jpeg_quality, "JPEG quality [1, 100]");
  app.add_option("--measure-encodings", measure,
                 "print bytes per frame of every encoding for the first N source frames and exit (no LCM)");
  CLI11_PARSE(app, argc, argv);

  setup_logging("capture", 0);
  install_signal_handlers();
  try {
    const YAML::Node root = load_config_file(config_path);
    CaptureSettings settings = load_capture_settings(config_section(root, "capture"));
    const auto given = [](const CLI::Option* option) { return option->count() > 0; };
    if (given(o_source)) settings.source = cli.source;
    if (given(o_scenario)) settings.scenario = cli.scenario;
    if (given(o_seed)) settings.seed = cli.seed;
    if (given(o_sim_frames)) settings.sim_frames = cli.sim_frames;
    if (given(o_folder)) settings.tum_folder = cli.tum_folder;
    if (given(o_depth_scale)) settings.depth_scale = cli.depth_scale;
    if (given(o_log)) settings.log_file = cli.log_file;
    if (given(o_oni)) settings.oni_file = cli.oni_file;
    if (given(o_uri)) settings.device_uri = cli.device_uri;
    if (given(o_rate)) settings.rate = parse_rate_mode(rate);
    if (given(o_speed)) settings.speed = cli.speed;
    if (given(o_timeout)) settings.lockstep_timeout_s = cli.lockstep_timeout_s;
    if (given(o_window)) settings.lockstep_window = cli.lockstep_window;
    if (given(o_max)) settings.max_frames = cli.max_frames;
    if (given(o_start)) settings.start_frame = cli.start_frame;
    if (given(o_loop)) settings.loop = cli.loop;
    if (given(o_truth)) settings.groundtruth_dir = cli.groundtruth_dir;
    if (given(o_depth)) settings.encoding.depth = parse_depth_encoding(depth_encoding);
    if (given(o_color)) settings.encoding.color = parse_color_encoding(color_encoding);
    if (given(o_quality)) settings.encoding.jpeg_quality = cli.encoding.jpeg_quality;
    settings.validate();

    auto source = make_source(settings, [] { return stop_requested(); });
    if (measure > 0) {
      if (settings.start_frame > 0) source->seek(settings.start_frame);
      return measure_encodings(*source, settings.encoding, measure);
    }
    install_group_security(root);
    lcm::LCM lcm(lcm_url(lcm_url_arg));
    if (!lcm.good()) {
      spdlog::error("cannot open LCM at {}", lcm_url(lcm_url_arg));
      return 1;
    }
    return run_capture_service(lcm, std::move(settings), std::move(source));
  } catch (const ConfigError& e) {
    spdlog::error("configuration refused: {}", e.what());
    return 2;
  } catch (const mfot::service::OutputError& e) {
    spdlog::error("output failed: {}", e.what());
    return mfot::service::kExitOutputFailed;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
