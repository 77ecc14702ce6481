// mfot-simulate: renders a simulator scenario (mfot/sim/simulator.hpp) to a TUM RGB-D folder
// (rgb.txt, depth.txt, rgb/, depth/, intrinsics.txt) with ground truth (groundtruth/poses.csv,
// groundtruth/labels/), to be replayed by `mfot-capture --source tum` and scored offline. Shows
// progress (frames done, rate, time left); Ctrl-C stops after the frame being written, and every
// frame on disk is complete (images are renamed into place before they are listed).

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <string>

#include "mfot/capture/sim_source.hpp"
#include "mfot/service/lcm_util.hpp"
#include "mfot/service/tum_dataset.hpp"

int main(int argc, char** argv) {
  using Clock = std::chrono::steady_clock;
  CLI::App app{"mfot-simulate: render a simulator scenario to a TUM RGB-D folder with ground truth"};
  mfot::sim::SimulatorOptions options;
  std::string output;
  bool no_noise = false;
  double depth_scale = 5000.0;
  app.add_option("output", output, "folder to create (must not already hold a dataset)")->required();
  app.add_option("--scenario", options.scenario.name,
                 "stack | contact | rotate | apart | static | random | spin | tumble | slide | cross | procedural "
                 "(procedural: a seeded generated scene, its motion class, shapes and mover in groundtruth/scene.yaml)")
      ->check(CLI::IsMember(mfot::sim::scenario_names()));
  app.add_option("--seed", options.scenario.seed,
                 "scenario and sensor-noise seed; procedural: 1-999 for development, 1000 and up for acceptance only "
                 "(never tune on them)");
  app.add_option("--frames", options.scenario.num_frames, "frames to render, 0 = the scenario's own length");
  app.add_option("--num-objects", options.scenario.num_objects, "random scenario: objects [1, 16]");
  app.add_option("--object-speed", options.scenario.speed, "random scenario: mean object speed, m/s (0, 0.2]");
  app.add_option("--occlusion", options.scenario.occlusion, "random scenario: share of time hands occlude [0, 1]");
  app.add_flag("--no-noise", no_noise, "exact geometry: no sensor noise or dropouts besides the range limits");
  app.add_option("--depth-scale", depth_scale, "depth PNG units per metre (TUM: 5000)");
  CLI11_PARSE(app, argc, argv);

  mfot::service::setup_logging("simulate", 0);
  mfot::service::install_signal_handlers();
  try {
    options.sensor.noise = !no_noise;
    const mfot::sim::Simulator simulator(options);
    mfot::service::TumWriterOptions writer_options;
    writer_options.folder = output;
    writer_options.depth_scale = depth_scale;
    mfot::service::TumDatasetWriter writer(writer_options);
    writer.write_scene(simulator.summary().yaml());

    const int total = simulator.num_frames();
    spdlog::info("rendering scenario '{}' (seed {}, {}): {} frames at {}x{} to {}", options.scenario.name,
                 options.scenario.seed, simulator.summary().source_name(), total, options.camera.width,
                 options.camera.height, output);
    const auto start = Clock::now();
    auto last_report = start;
    int done = 0;
    for (; done < total && !mfot::service::stop_requested(); ++done) {
      const mfot::capture::SourceFrame item = mfot::capture::to_source_frame(simulator.render(done));
      writer.write(item.frame, &*item.truth);
      const auto now = Clock::now();
      if (now - last_report >= std::chrono::seconds(1) || done + 1 == total) {
        last_report = now;
        const double elapsed = std::chrono::duration<double>(now - start).count();
        const double rate = (done + 1) / elapsed;
        spdlog::info("{}/{} frames ({:.0f}%), {:.1f} frames/s, {:.0f} s left", done + 1, total,
                     100.0 * (done + 1) / total, rate, (total - done - 1) / rate);
      }
    }
    if (writer.depth_pixels_clipped() > 0) {
      spdlog::warn("{} depth pixels beyond the 16-bit range at depth scale {} were written as 0 (no measurement)",
                   writer.depth_pixels_clipped(), depth_scale);
    }
    if (done < total) {
      spdlog::warn("interrupted: {} of {} frames written; every listed frame in {} is complete", done, total, output);
      return 130;
    }
    spdlog::info("done: {} frames in {}", total, output);
    return 0;
  } catch (const std::invalid_argument& e) {
    spdlog::error("invalid option: {}", e.what());
    return 2;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
