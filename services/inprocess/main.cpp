// mfot-inprocess: the whole pipeline in one process with direct calls, no LCM: source ->
// frame encoding (as on the wire) -> Preprocessor -> one ParticleFilter per object ->
// ObjectManager, with the same config sections as the services. It measures the method without
// the transport (compare its rate with scripts/mfot-run's) and serves integration tests.

#include "mfot/capture/capture_settings.hpp"
#include "mfot/capture/frame_source.hpp"
#include "mfot/metrics.hpp"
#include "mfot/tracking_step.hpp"
#include "mfot/service/convert.hpp"
#include "mfot/service/frame_codec.hpp"
#include "mfot/service/lcm_util.hpp"
#include "mfot/service/pipeline_config.hpp"
#include "mfot/service/service_main.hpp"
#include "mfot/service/run_writer.hpp"
#include "mfot/service/tum_dataset.hpp"

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <vector>

namespace mfot::service {
namespace {

using Clock = std::chrono::steady_clock;

// One object's tracker, as a tracker worker runs it (services/tracker).
struct ObjectTracker {
  LikelihoodChoice likelihood;
  std::unique_ptr<ParticleFilter> filter;
  std::unique_ptr<TrackingStep> step;  // counts this object's holds
  Eigen::AlignedBox3f model_box;
};

struct Options {
  std::string config_path = "configs/default.yaml";
  std::string scenario;
  std::int64_t max_frames = 0;
  std::string backend;
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
  const PreprocessorOptions preprocess_options = load_preprocess_config(root).preprocessor;
  TrackerConfig tracker_config = load_tracker_config(root);
  if (!cli.backend.empty()) {
    tracker_config.likelihood.backend = cli.backend == "cuda"             ? LikelihoodBackend::kCuda
                                        : cli.backend == "cpu"            ? LikelihoodBackend::kCpu
                                        : cli.backend == "point-to-point" ? LikelihoodBackend::kPointToPoint
                                                                          : LikelihoodBackend::kAuto;
  }
  const MergerConfig merger_config = load_merger_config(root);

  auto source = capture::make_source(capture, [] { return stop_requested(); });
  Preprocessor preprocessor(preprocess_options);
  ObjectManager manager(merger_config.manager);
  std::map<std::int32_t, ObjectTracker> trackers;
  std::unique_ptr<RunWriter> writer;
  std::unique_ptr<GroundTruthWriter> truth_writer;
  FittingDistanceEvaluator fitting;
  std::ofstream timing;  // per-frame time, compared with the baselines' (scripts/bench-baselines)
  if (!cli.out_dir.empty()) {
    writer = std::make_unique<RunWriter>(cli.out_dir);
    truth_writer = std::make_unique<GroundTruthWriter>(cli.out_dir + "/groundtruth");
    timing.open(cli.out_dir + "/timing.csv");
    if (!timing) throw std::runtime_error(cli.out_dir + "/timing.csv: cannot create file");
    timing << "frame,frame_ms,cpu_ms\n";
  }

  // Per-stage milliseconds of every frame, so the summary shows where a frame's time goes.
  std::vector<double> frame_ms, codec_ms, preprocess_ms, track_ms, merge_ms;
  const auto ms_since = [](Clock::time_point t) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
  };
  Scene scene;
  std::int64_t seq = 0;
  const auto start = Clock::now();
  while (!stop_requested() && (capture.max_frames <= 0 || seq < capture.max_frames)) {
    std::optional<capture::SourceFrame> item = source->next();
    if (!item) break;
    const auto t0 = Clock::now();
    const std::clock_t cpu0 = std::clock();  // process CPU time: the cost of a frame on a shared machine
    // The frame as the services see it after the wire's (possibly lossy) encoding.
    const Frame frame = decode_frame(encode_frame(item->frame, capture.encoding, seq, source->name(), now_utime()));
    codec_ms.push_back(ms_since(t0));
    const auto t_preprocess = Clock::now();
    RgbdImageView view;
    view.width = frame.width;
    view.height = frame.height;
    view.intrinsics = {frame.fx, frame.fy, frame.cx, frame.cy};
    view.depth_mm = frame.depth_mm;
    view.color = frame.color;
    const SceneCloud& cloud = preprocessor.process(view);
    scene.cloud.clear();
    scene.cloud.positions = cloud.positions;
    scene.cloud.colors = cloud.colors;
    scene.cluster.assign(cloud.cluster.begin(), cloud.cluster.end());
    scene.features = compute_smr(scene.cloud.colors);
    preprocess_ms.push_back(ms_since(t_preprocess));

    const auto t_track = Clock::now();
    std::map<std::int32_t, ObjectEstimate> estimates;
    for (auto& [id, tracker] : trackers) {
      const ObjectModel& model = manager.objects().at(id).model;
      const TrackingStepResult step = tracker.step->track(scene.cloud, scene.features, model, tracker.model_box,
                                                          *tracker.filter, *tracker.likelihood.likelihood);
      estimates[id] = {step.estimate, tracker.filter->confidence()};
      spdlog::debug("frame {} object {} ({} model points): {} share {:.2f}, {} points scored, {} occluders left out, "
                    "t [{:.3f} {:.3f} {:.3f}]",
                    seq, id, model.cloud.size(), step.held ? "held" : "stepped", step.occluded_share,
                    step.hypothesis_points, step.occluders_removed, step.estimate.translation.x(),
                    step.estimate.translation.y(), step.estimate.translation.z());
    }
    track_ms.push_back(ms_since(t_track));
    const auto t_merge = Clock::now();
    const ObjectManagerFrame& result = manager.process(scene.cloud, scene.cluster, estimates);
    for (const std::int32_t id : result.retired) trackers.erase(id);
    for (const auto& [id, object] : manager.objects()) {
      auto [it, created] = trackers.try_emplace(id);
      ObjectTracker& tracker = it->second;
      if (created) {
        tracker.likelihood = make_likelihood(tracker_config.likelihood);
        ParticleFilterOptions options = tracker_config.filter;
        options.seed = tracker_config.filter.seed + static_cast<std::uint64_t>(id);
        tracker.filter = std::make_unique<ParticleFilter>(options);
        tracker.filter->reset(object.pose);
        tracker.step = std::make_unique<TrackingStep>(tracker_config.step);
      }
      tracker.model_box = model_bounding_box(object.model);
      tracker.likelihood.likelihood->set_model(object.model);
    }
    merge_ms.push_back(ms_since(t_merge));
    frame_ms.push_back(ms_since(t0));

    const double cpu_ms = 1000.0 * static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;
    if (writer) {
      if (merger_config.fitting_distance) fitting.set_scene(scene.cloud.positions);
      for (const auto& [id, object] : manager.objects()) {
        writer->write_pose(seq, frame.capture_utime, id, object.pose, object.confidence, object.stale);
        if (merger_config.fitting_distance && !scene.cloud.empty()) {
          writer->write_fitting(seq, id, fitting.evaluate(object.model.cloud.positions, object.pose).mean);
        }
      }
      timing << seq << ',' << frame_ms.back() << ',' << cpu_ms << '\n';
      writer->write_labels(seq, dense_labels(frame.width, frame.height, frame.fx, frame.fy, frame.cx, frame.cy,
                                             frame.depth_mm, preprocess_options.voxel_size, scene.cloud.positions,
                                             result.labels));
      if (item->truth) {
        GroundTruthFrame truth = *item->truth;
        truth.frame = seq;
        truth_writer->write(truth);
      }
    }
    ++seq;
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  if (writer) writer->flush();
  const auto pct = [](std::vector<double> values, double q) {
    if (values.empty()) return 0.0;
    std::sort(values.begin(), values.end());
    return values[static_cast<std::size_t>(q * static_cast<double>(values.size() - 1))];
  };
  spdlog::info("{} frames in {:.2f} s: {:.1f} frames/s; per frame p50 {:.1f} ms, p99 {:.1f} ms; {} objects at the end",
               seq, seconds, static_cast<double>(seq) / std::max(seconds, 1e-9), pct(frame_ms, 0.5),
               pct(frame_ms, 0.99), manager.objects().size());
  spdlog::info("stage p50 (ms): wire codec {:.2f}, preprocess {:.2f}, trackers {:.2f}, merger {:.2f}",
               pct(codec_ms, 0.5), pct(preprocess_ms, 0.5), pct(track_ms, 0.5), pct(merge_ms, 0.5));
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
  CLI11_PARSE(app, argc, argv);
  setup_logging("inprocess", 0);
  install_signal_handlers();
  return run_service_main([&] {
    return run(options);
  });
}
