// mfot-pcl-baseline: PCL's own tracker on mfot's frames, for comparison (issue 7). The same source
// and frame encoding as mfot-inprocess, the same preprocessing (our Preprocessor), objects from the
// same first-frame clusters (our ObjectManager's first frame), then one
// pcl::tracking::KLDAdaptiveParticleFilterOMPTracker per object with DistanceCoherence and
// HSVColorCoherence (PCL's tracking example settings, configs/pcl_baseline.yaml) fed the same
// preprocessed scene. PCL's tracker has a fixed reference and never adds objects, so no model
// update and no new objects after the first frame. Scene points are labelled with the object of
// the nearest tracked model point (our Segmenter, merger.tau) and the run folder has mfot's format
// (poses.csv, labels/, fitting.csv, timing.csv, groundtruth/) so mfot-evaluate scores it.
//
// Random draws: PCL's tracker samples from generators inside libpcl_tracking (a std::mt19937
// seeded from std::random_device in its resampler, sampleNormal's own static generator) that its
// API cannot seed, and from the C library's rand(), which we seed from pcl_baseline.seed. Runs are
// therefore not bit-reproducible, unlike mfot's.

#include "pcl_object_tracker.hpp"

#include "mfot/capture/capture_settings.hpp"
#include "mfot/capture/frame_source.hpp"
#include "mfot/metrics.hpp"
#include "mfot/service/frame_codec.hpp"
#include "mfot/service/lcm_util.hpp"
#include "mfot/service/pipeline_config.hpp"
#include "mfot/service/run_writer.hpp"
#include "mfot/service/service_main.hpp"
#include "mfot/service/tum_dataset.hpp"

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <vector>

namespace mfot::service {
namespace {

using Clock = std::chrono::steady_clock;
using pcl_baseline::PclObjectTracker;
using pcl_baseline::PclScene;
using pcl_baseline::PclTrackerSettings;
using pcl_baseline::PlainPose;

struct BaselineConfig {
  PclTrackerSettings tracker;
  unsigned seed = 1;
};

// Section pcl_baseline of the baseline's own config file laid over configs/default.yaml (strict like
// the services' configs).
BaselineConfig load_baseline_config(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw ConfigError(path + ": cannot open config file");
  } catch (const YAML::ParserException& e) {
    throw ConfigError(path + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax error: " + e.msg);
  }
  try {
    check_top_level(root, {"pcl_baseline"});
  } catch (const ConfigError& e) {
    throw ConfigError(path + ": " + e.what());
  }
  root = merged_over_defaults(root);
  BaselineConfig c;
  PclTrackerSettings& t = c.tracker;
  auto s = config_section(root, "pcl_baseline");
  t.particles = s.get<int>("particles", 1, 100000);
  t.max_particles = s.get<int>("max_particles", 1, 100000);
  t.kld_delta = s.get<double>("kld_delta", 1e-6, 1.0 - 1e-6);
  t.kld_epsilon = s.get<double>("kld_epsilon", 1e-6, 10.0);
  t.bin_size = s.get<double>("bin_size", 1e-6, 10.0);
  const auto to_array = [](const std::vector<double>& v) {
    std::array<double, 6> a{};
    std::copy(v.begin(), v.end(), a.begin());
    return a;
  };
  t.step_noise_sigma = to_array(s.get_vector("step_noise_sigma", 6));
  t.initial_noise_sigma = to_array(s.get_vector("initial_noise_sigma", 6));
  t.iterations = s.get<int>("iterations", 1, 100);
  t.color_weight = s.get<double>("color_weight", 0.0, 100.0);
  t.max_distance = s.get<double>("max_distance", 1e-6, 1.0);
  t.octree_resolution = s.get<double>("octree_resolution", 1e-4, 1.0);
  t.reference_leaf = s.get<float>("reference_leaf", 0.f, 0.1f);
  t.threads = s.get<int>("threads", 1, 256);
  c.seed = static_cast<unsigned>(s.get<std::uint64_t>("seed", 0, 4294967295u));  // srand takes 32 bits
  s.finish();
  try {
    t.validate();  // cross-field rule: max_particles >= particles
  } catch (const std::invalid_argument& e) {
    throw ConfigError(path + ": " + e.what());
  }
  return c;
}

PlainPose to_plain(const Pose& pose) {
  PlainPose p;
  p.translation = {pose.translation.x(), pose.translation.y(), pose.translation.z()};
  p.rotation = {pose.rotation.x(), pose.rotation.y(), pose.rotation.z(), pose.rotation.w()};
  return p;
}

Pose from_plain(const PlainPose& p) {
  Pose pose;
  pose.translation = Eigen::Vector3f(p.translation[0], p.translation[1], p.translation[2]);
  pose.rotation = Eigen::Quaternionf(p.rotation[3], p.rotation[0], p.rotation[1], p.rotation[2]).normalized();
  return pose;
}

void flatten(const ColoredCloud& cloud, std::vector<float>& xyz, std::vector<std::uint8_t>& rgb) {
  xyz.resize(3 * cloud.size());
  rgb.resize(3 * cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    for (int k = 0; k < 3; ++k) xyz[3 * i + k] = cloud.positions[i][k];
    rgb[3 * i] = cloud.colors[i].r;
    rgb[3 * i + 1] = cloud.colors[i].g;
    rgb[3 * i + 2] = cloud.colors[i].b;
  }
}

// One object: PCL's tracker, and the model (our first-frame model, the tracker's reference) for
// labels and the fitting distance.
struct BaselineObject {
  std::unique_ptr<PclObjectTracker> tracker;
  std::vector<Eigen::Vector3f> model_points;  // object frame
  Pose pose;
};

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
  const PreprocessorOptions preprocess_options = load_preprocess_config(root).preprocessor;
  const MergerConfig merger_config = load_merger_config(root);
  const BaselineConfig baseline = load_baseline_config(cli.baseline_config_path);
  std::srand(baseline.seed);  // the one generator of PCL's tracker that can be seeded (see the top)

  auto source = capture::make_source(capture, [] { return stop_requested(); });
  Preprocessor preprocessor(preprocess_options);
  ObjectManager first_frame_objects(merger_config.manager);
  Segmenter segmenter(merger_config.manager.segmentation);
  FittingDistanceEvaluator fitting;
  std::map<std::int32_t, BaselineObject> objects;
  std::unique_ptr<RunWriter> writer;
  std::unique_ptr<GroundTruthWriter> truth_writer;
  std::ofstream timing;
  if (!cli.out_dir.empty()) {
    writer = std::make_unique<RunWriter>(cli.out_dir);
    truth_writer = std::make_unique<GroundTruthWriter>(cli.out_dir + "/groundtruth");
    timing.open(cli.out_dir + "/timing.csv");
    if (!timing) throw std::runtime_error(cli.out_dir + "/timing.csv: cannot create file");
    timing << "frame,frame_ms,cpu_ms,track_ms,particles\n";
  }

  std::vector<double> frame_ms_all;
  ColoredCloud scene;
  std::vector<std::int32_t> clusters;
  std::vector<float> scene_xyz;
  std::vector<std::uint8_t> scene_rgb;
  PclScene pcl_scene;
  std::vector<SegmentationObject> seg_objects;
  SegmentationResult segmentation;
  std::int64_t seq = 0;
  const auto start = Clock::now();
  while (!stop_requested() && (capture.max_frames <= 0 || seq < capture.max_frames)) {
    std::optional<capture::SourceFrame> item = source->next();
    if (!item) break;
    const auto t0 = Clock::now();
    const std::clock_t cpu0 = std::clock();  // process CPU time: the cost of a frame on a shared machine
    // The frame as the services see it after the wire's (possibly lossy) encoding.
    const Frame frame = decode_frame(encode_frame(item->frame, capture.encoding, seq, source->name(), now_utime()));
    RgbdImageView view;
    view.width = frame.width;
    view.height = frame.height;
    view.intrinsics = {frame.fx, frame.fy, frame.cx, frame.cy};
    view.depth_mm = frame.depth_mm;
    view.color = frame.color;
    const SceneCloud& cloud = preprocessor.process(view);
    scene.positions = cloud.positions;
    scene.colors = cloud.colors;
    clusters.assign(cloud.cluster.begin(), cloud.cluster.end());

    double track_ms = 0.0;
    int particles = 0;
    const std::vector<std::int32_t>* labels = nullptr;
    if (seq == 0) {
      // Objects from the first frame's clusters, exactly as mfot creates them.
      const ObjectManagerFrame& result = first_frame_objects.process(scene, clusters, {});
      std::vector<float> ref_xyz;
      std::vector<std::uint8_t> ref_rgb;
      for (const auto& [id, object] : first_frame_objects.objects()) {
        flatten(object.model.cloud, ref_xyz, ref_rgb);
        BaselineObject& b = objects[id];
        b.tracker = std::make_unique<PclObjectTracker>(baseline.tracker, ref_xyz, ref_rgb, to_plain(object.pose));
        b.model_points = object.model.cloud.positions;
        b.pose = object.pose;
      }
      spdlog::info("{} objects from the first frame's clusters", objects.size());
      labels = &result.labels;
    } else {
      const auto track_start = Clock::now();
      if (!scene.empty()) {
        flatten(scene, scene_xyz, scene_rgb);
        pcl_scene.assign(scene_xyz, scene_rgb);
        for (auto& [id, object] : objects) {
          object.pose = from_plain(object.tracker->track(pcl_scene));
          particles += object.tracker->particles_used();
        }
      }  // an empty scene leaves every pose as it was: PCL's search needs a target
      track_ms = std::chrono::duration<double, std::milli>(Clock::now() - track_start).count();
      seg_objects.clear();
      for (const auto& [id, object] : objects) seg_objects.push_back({id, object.model_points, object.pose});
      segmenter.segment(scene.positions, seg_objects, segmentation);
      labels = &segmentation.labels;
    }
    const double frame_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    frame_ms_all.push_back(frame_ms);
    const double cpu_ms = 1000.0 * static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;

    if (writer) {
      if (merger_config.fitting_distance) fitting.set_scene(scene.positions);
      for (const auto& [id, object] : objects) {
        // PCL's tracker reports no confidence in [0, 1]; every pose is written as confident.
        writer->write_pose(seq, frame.capture_utime, id, object.pose, 1.f, false);
        if (merger_config.fitting_distance && !scene.empty()) {
          writer->write_fitting(seq, id, fitting.evaluate(object.model_points, object.pose).mean);
        }
      }
      writer->write_labels(seq, dense_labels(frame.width, frame.height, frame.fx, frame.fy, frame.cx, frame.cy,
                                             frame.depth_mm, preprocess_options.voxel_size, scene.positions, *labels));
      timing << seq << ',' << frame_ms << ',' << cpu_ms << ',' << track_ms << ',' << particles << '\n';
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
  std::sort(frame_ms_all.begin(), frame_ms_all.end());
  const auto pct = [&](double q) {
    return frame_ms_all.empty() ? 0.0
                                : frame_ms_all[static_cast<std::size_t>(q * static_cast<double>(frame_ms_all.size() - 1))];
  };
  double mean = 0.0;
  for (const double ms : frame_ms_all) mean += ms / static_cast<double>(frame_ms_all.size());
  spdlog::info("{} frames in {:.2f} s: {:.1f} frames/s; per frame mean {:.1f} ms, p50 {:.1f} ms, p99 {:.1f} ms; {} objects",
               seq, seconds, static_cast<double>(seq) / std::max(seconds, 1e-9), mean, pct(0.5), pct(0.99),
               objects.size());
  return seq > 0 ? 0 : 1;
}

}  // namespace
}  // namespace mfot::service

int main(int argc, char** argv) {
  using namespace mfot::service;
  CLI::App app{"mfot-pcl-baseline: PCL's KLD particle filter tracker on mfot's frames, for comparison"};
  Options options;
  app.add_option("--config", options.config_path, "YAML config (sections capture, preprocess, merger)")
      ->capture_default_str();
  app.add_option("--baseline-config", options.baseline_config_path, "YAML config with section pcl_baseline")
      ->capture_default_str();
  app.add_option("--scenario", options.scenario, "simulator scenario (overrides the capture source)");
  app.add_option("--max-frames", options.max_frames, "stop after this many frames (0: the whole source)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--out", options.out_dir, "write poses.csv, labels/, fitting.csv, timing.csv and groundtruth/ here");
  CLI11_PARSE(app, argc, argv);
  setup_logging("pcl-baseline", 0);
  install_signal_handlers();
  return run_service_main([&] {
    return run(options);
  });
}
