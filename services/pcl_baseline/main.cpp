// mfot-pcl-baseline: PCL's own tracker on mfot's frames, for comparison (issue 7). The same source
// and frame encoding as mfot-inprocess, the same preprocessing (our Preprocessor), objects from the
// same first-frame clusters (our ObjectManager's first frame), then one
// pcl::tracking::KLDAdaptiveParticleFilterOMPTracker per object with DistanceCoherence and
// HSVColorCoherence (PCL's tracking example settings, section pcl_baseline of configs/default.yaml) fed the same
// preprocessed scene. PCL's tracker has a fixed reference and never adds objects, so no model
// update and no new objects after the first frame. Scene points are labelled with the object of
// the nearest tracked model point (our Segmenter, merger.tau) and the run folder has mfot's format
// (poses.csv, labels/, fitting.csv, timing.csv, groundtruth/) so mfot-evaluate scores it.
//
// Random draws: PCL's tracker samples from generators inside libpcl_tracking (a std::mt19937
// seeded from std::random_device in its resampler, sampleNormal's own static generator) that its
// API cannot seed, and from the C library's rand(), which we seed from pcl_baseline.seed. Runs are
// therefore not bit-reproducible, unlike mfot's.

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <memory>
#include <numeric>
#include <optional>
#include <vector>

#include "baseline_pipeline.hpp"
#include "mfot/capture/capture_settings.hpp"
#include "mfot/percentile.hpp"
#include "mfot/service/lcm_util.hpp"
#include "mfot/service/pipeline_config.hpp"
#include "mfot/service/run_outputs.hpp"
#include "mfot/service/service_main.hpp"
#include "mfot/service/tum_dataset.hpp"

namespace mfot::service {
namespace {

using Clock = std::chrono::steady_clock;

struct Options {
  std::string config_path;  // empty: the built-in defaults (configs/default.yaml)
  std::string baseline_config_path = "configs/pcl_baseline.yaml";
  std::string scenario;
  std::int64_t max_frames = 0;
  std::string out_dir;
};

int run(const Options& cli) {
  const YAML::Node root = load_config_file(cli.config_path);
  capture::CaptureSettings capture = capture::load_capture_settings(config_section(root, "capture"));
  if (!cli.scenario.empty()) {
    capture.source = "sim";
    capture.scenario = cli.scenario;
  }
  if (cli.max_frames > 0) capture.max_frames = cli.max_frames;
  capture.validate();
  const MergerConfig merger = load_merger_config(root);
  const BaselineConfig baseline = load_baseline_config(cli.baseline_config_path);
  std::srand(baseline.seed);  // the one generator of PCL's tracker that can be seeded (see the top)
  BaselinePipeline pipeline(
      {capture.encoding, load_preprocess_config(root).preprocessor, merger.manager, baseline.tracker});

  auto source = capture::make_source(capture, [] { return stop_requested(); });
  MalformedCounter malformed;  // undecodable frames for label images (none: the frames are our own)
  std::unique_ptr<RunOutputs> outputs;
  std::unique_ptr<GroundTruthWriter> truth_writer;
  std::ofstream timing;
  if (!cli.out_dir.empty()) {
    outputs = std::make_unique<RunOutputs>(
        cli.out_dir, false, RunOutputsOptions{merger.write_labels, merger.fitting_distance, false}, malformed);
    truth_writer = std::make_unique<GroundTruthWriter>(cli.out_dir + "/groundtruth");
    timing.open(cli.out_dir + "/timing.csv");
    if (!timing) throw std::runtime_error(cli.out_dir + "/timing.csv: cannot create file");
    timing << "frame,frame_ms,cpu_ms,track_ms,particles\n";
  }

  std::vector<double> frame_ms_all;
  std::int64_t seq = 0;
  const auto start = Clock::now();
  while (!stop_requested() && (capture.max_frames <= 0 || seq < capture.max_frames)) {
    std::optional<capture::SourceFrame> item = source->next();
    if (!item) break;
    const auto t0 = Clock::now();
    const std::clock_t cpu0 = std::clock();  // process CPU time: the cost of a frame on a shared machine
    pipeline.process(item->frame, seq, source->name());
    const double frame_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    frame_ms_all.push_back(frame_ms);
    const double cpu_ms = 1000.0 * static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;
    if (outputs) {
      outputs->write_poses(seq, pipeline.scene().capture_utime, pipeline.objects());
      outputs->write_frame(pipeline.scene(), pipeline.labels(), pipeline.objects(), pipeline.message());
      timing << seq << ',' << frame_ms << ',' << cpu_ms << ',' << pipeline.track_ms() << ','
             << pipeline.particles_used() << '\n';
      if (item->truth) {
        GroundTruthFrame truth = *item->truth;
        truth.frame = seq;
        truth_writer->write(truth);
      }
    }
    ++seq;
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  if (outputs) outputs->finish();
  const double mean = frame_ms_all.empty() ? 0.0
                                           : std::accumulate(frame_ms_all.begin(), frame_ms_all.end(), 0.0) /
                                                 static_cast<double>(frame_ms_all.size());
  spdlog::info(
      "{} frames in {:.2f} s: {:.1f} frames/s; per frame mean {:.1f} ms, p50 {:.1f} ms, p99 {:.1f} ms; {} objects", seq,
      seconds, static_cast<double>(seq) / std::max(seconds, 1e-9), mean, percentile(frame_ms_all, 0.5),
      percentile(frame_ms_all, 0.99), pipeline.objects().size());
  return seq > 0 ? 0 : 1;
}

}  // namespace
}  // namespace mfot::service

int main(int argc, char** argv) {
  using namespace mfot::service;
  CLI::App app{"mfot-pcl-baseline: PCL's KLD particle filter tracker on mfot's frames, for comparison"};
  Options options;
  app.add_option("--config", options.config_path, "YAML config (sections capture, preprocess, merger)");
  app.add_option("--baseline-config", options.baseline_config_path, "YAML config with section pcl_baseline")
      ->capture_default_str();
  app.add_option("--scenario", options.scenario, "simulator scenario (overrides the capture source)");
  app.add_option("--max-frames", options.max_frames, "stop after this many frames (0: the whole source)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--out", options.out_dir, "write poses.csv, labels/, fitting.csv, timing.csv and groundtruth/ here");
  CLI11_PARSE(app, argc, argv);
  setup_logging("pcl-baseline", 0);
  install_signal_handlers();
  return run_service_main([&] { return run(options); });
}
