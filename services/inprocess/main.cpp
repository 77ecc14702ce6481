// mfot-inprocess: the whole pipeline in one process with direct calls, no LCM (InprocessPipeline:
// wire encoding -> Preprocessor -> one ObjectTracker per object -> ObjectManager), with the same
// config sections as the services. It measures the method without the transport (compare its
// rate with scripts/mfot-run's) and serves integration tests and baselines.

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <ctime>
#include <fstream>
#include <memory>
#include <optional>
#include <vector>

#include "mfot/capture/capture_settings.hpp"
#include "mfot/percentile.hpp"
#include "mfot/service/inprocess_pipeline.hpp"
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
  std::string scenario;
  std::int64_t max_frames = 0;
  std::string backend;
  std::string out_dir;
  std::string json_path;
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
  TrackerConfig tracker = load_tracker_config(root);
  if (!cli.backend.empty()) tracker.likelihood.backend = parse_likelihood_backend(cli.backend);
  const MergerConfig merger = load_merger_config(root);
  InprocessPipeline pipeline(
      {capture.encoding, load_preprocess_config(root).preprocessor, tracker, merger.manager, merger.threads});

  auto source = capture::make_source(capture, [] { return stop_requested(); });
  MalformedCounter malformed;  // undecodable frames for label images (none: the frames are our own)
  std::unique_ptr<RunOutputs> outputs;
  std::unique_ptr<GroundTruthWriter> truth_writer;
  std::ofstream timing;  // per-frame time, compared with the baselines' (scripts/bench-baselines)
  if (!cli.out_dir.empty()) {
    outputs = std::make_unique<RunOutputs>(
        cli.out_dir, false, RunOutputsOptions{merger.write_labels, merger.fitting_distance, false}, malformed);
    truth_writer = std::make_unique<GroundTruthWriter>(cli.out_dir + "/groundtruth");
    truth_writer->write_scene(source->scene_yaml());
    timing.open(cli.out_dir + "/timing.csv");
    if (!timing) throw std::runtime_error(cli.out_dir + "/timing.csv: cannot create file");
    timing << "frame,frame_ms,cpu_ms\n";
  }

  // Per-stage milliseconds of every frame, so the summary shows where a frame's time goes.
  std::vector<double> frame_ms, codec_ms, preprocess_ms, track_ms, merge_ms;
  std::int64_t seq = 0;
  const auto start = Clock::now();
  while (!stop_requested() && (capture.max_frames <= 0 || seq < capture.max_frames)) {
    std::optional<capture::SourceFrame> item = source->next();
    if (!item) break;
    const auto t0 = Clock::now();
    const std::clock_t cpu0 = std::clock();  // process CPU time: the cost of a frame on a shared machine
    const InprocessFrame& frame = pipeline.process(item->frame, seq, source->name());
    frame_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    codec_ms.push_back(frame.times.codec_ms);
    preprocess_ms.push_back(frame.times.preprocess_ms);
    track_ms.push_back(frame.times.track_ms);
    merge_ms.push_back(frame.times.merge_ms);
    const double cpu_ms = 1000.0 * static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;
    if (outputs) {
      const auto& objects = pipeline.manager().objects();
      outputs->write_poses(seq, frame.scene.capture_utime, objects);
      outputs->write_frame(frame.scene, pipeline.result().labels, objects, frame.message);
      timing << seq << ',' << frame_ms.back() << ',' << cpu_ms << '\n';
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
  spdlog::info("{} frames in {:.2f} s: {:.1f} frames/s; per frame p50 {:.1f} ms, p99 {:.1f} ms; {} objects at the end",
               seq, seconds, static_cast<double>(seq) / std::max(seconds, 1e-9), percentile(frame_ms, 0.5),
               percentile(frame_ms, 0.99), pipeline.manager().objects().size());
  spdlog::info("stage p50 (ms): wire codec {:.2f}, preprocess {:.2f}, trackers {:.2f}, merger {:.2f}",
               percentile(codec_ms, 0.5), percentile(preprocess_ms, 0.5), percentile(track_ms, 0.5),
               percentile(merge_ms, 0.5));
  if (!cli.json_path.empty()) {
    std::ofstream json(cli.json_path);
    json << fmt::format(
        "{{\"frames\": {}, \"seconds\": {:.4f}, \"fps\": {:.3f}, \"frame_ms_p50\": {:.3f}, \"frame_ms_p99\": {:.3f}, "
        "\"objects\": {}, \"stage_ms_p50\": {{\"codec\": {:.3f}, \"preprocess\": {:.3f}, \"trackers\": {:.3f}, "
        "\"merger\": {:.3f}}}}}\n",
        seq, seconds, static_cast<double>(seq) / std::max(seconds, 1e-9), percentile(frame_ms, 0.5),
        percentile(frame_ms, 0.99), pipeline.manager().objects().size(), percentile(codec_ms, 0.5),
        percentile(preprocess_ms, 0.5), percentile(track_ms, 0.5), percentile(merge_ms, 0.5));
    if (!json) throw std::runtime_error(cli.json_path + ": cannot write the summary");
  }
  return seq > 0 ? 0 : 1;
}

}  // namespace
}  // namespace mfot::service

int main(int argc, char** argv) {
  using namespace mfot::service;
  CLI::App app{"mfot-inprocess: the whole pipeline in one process, without LCM"};
  Options options;
  app.add_option("--config", options.config_path, "YAML config (sections capture, preprocess, tracker, merger)");
  app.add_option("--scenario", options.scenario, "simulator scenario (overrides the capture source)");
  app.add_option("--max-frames", options.max_frames, "stop after this many frames (0: the whole source)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--backend", options.backend, "likelihood backend")
      ->check(CLI::IsMember({"auto", "cuda", "cpu", "point-to-point"}));
  app.add_option("--out", options.out_dir, "write poses.csv, labels/, fitting.csv, timing.csv and groundtruth/ here");
  app.add_option("--json", options.json_path,
                 "write the summary (frames, frames/s, per-frame and per-stage ms) as JSON");
  CLI11_PARSE(app, argc, argv);
  setup_logging("inprocess", 0);
  install_signal_handlers();
  return run_service_main([&] { return run(options); });
}
