#include "baseline_pipeline.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <chrono>

#include "mfot/service/lcm_util.hpp"
#include "mfot/service/options.hpp"

namespace mfot::service {

using pcl_baseline::PclObjectTracker;
using pcl_baseline::PclTrackerSettings;
using pcl_baseline::PlainPose;

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
  t.particles = read_option<int>(s, "particles");
  t.max_particles = read_option<int>(s, "max_particles");
  t.kld_delta = read_option<double>(s, "kld_delta");
  t.kld_epsilon = read_option<double>(s, "kld_epsilon");
  t.bin_size = read_option<double>(s, "bin_size");
  const auto to_array = [](const std::vector<double>& v) {
    std::array<double, 6> a{};
    std::copy(v.begin(), v.end(), a.begin());
    return a;
  };
  t.step_noise_sigma = to_array(read_list(s, "step_noise_sigma"));
  t.initial_noise_sigma = to_array(read_list(s, "initial_noise_sigma"));
  t.iterations = read_option<int>(s, "iterations");
  t.color_weight = read_option<double>(s, "color_weight");
  t.max_distance = read_option<double>(s, "max_distance");
  t.octree_resolution = read_option<double>(s, "octree_resolution");
  t.reference_leaf = read_option<float>(s, "reference_leaf");
  t.threads = read_option<int>(s, "threads");
  c.seed = static_cast<unsigned>(read_option<std::uint64_t>(s, "seed"));  // srand takes 32 bits
  s.finish();
  try {
    t.validate();  // cross-field rule: max_particles >= particles
  } catch (const std::invalid_argument& e) {
    throw ConfigError(path + ": " + e.what());
  }
  return c;
}

namespace {

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

}  // namespace

BaselinePipeline::BaselinePipeline(const BaselineOptions& options)
    : options_(options),
      preprocessor_(options.preprocess),
      first_frame_objects_(options.manager, make_object_discovery(options.manager.discovery)),
      segmenter_(options.manager.segmentation) {}

void BaselinePipeline::process(const Frame& frame, std::int64_t seq, const std::string& source_name) {
  // The frame as the services see it after the wire's (possibly lossy) encoding.
  message_ = encode_frame(frame, options_.encoding, seq, source_name, now_utime());
  const Frame decoded = decode_frame(message_);
  scene_from_cloud(preprocessor_.process(image_view(decoded), seq), decoded, seq, scene_);
  track_ms_ = 0.0;
  particles_ = 0;
  if (seq == 0) {
    // Objects from the first frame's clusters, exactly as mfot creates them.
    const ObjectManagerFrame& result =
        first_frame_objects_.process(scene_.cloud, scene_.cluster, scene_.standing_clusters, {});
    std::vector<float> ref_xyz;
    std::vector<std::uint8_t> ref_rgb;
    for (const auto& [id, object] : first_frame_objects_.objects()) {
      flatten(object.model.cloud, ref_xyz, ref_rgb);
      trackers_[id] = std::make_unique<PclObjectTracker>(options_.tracker, ref_xyz, ref_rgb, to_plain(object.pose));
      ManagedObject& o = objects_[id];
      o.id = id;
      o.model.cloud = object.model.cloud;
      o.pose = object.pose;
      o.confidence = 1.f;
    }
    spdlog::info("{} objects from the first frame's clusters", objects_.size());
    labels_ = &result.labels;
    return;
  }
  const auto track_start = std::chrono::steady_clock::now();
  if (!scene_.cloud.empty()) {
    flatten(scene_.cloud, scene_xyz_, scene_rgb_);
    pcl_scene_.assign(scene_xyz_, scene_rgb_);
    for (auto& [id, tracker] : trackers_) {
      objects_.at(id).pose = from_plain(tracker->track(pcl_scene_));
      particles_ += tracker->particles_used();
    }
  }  // an empty scene leaves every pose as it was: PCL's search needs a target
  track_ms_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - track_start).count();
  seg_objects_.clear();
  for (const auto& [id, object] : objects_) seg_objects_.push_back({id, object.model.cloud.positions, object.pose});
  segmenter_.segment(scene_.cloud.positions, seg_objects_, segmentation_);
  labels_ = &segmentation_.labels;
}

}  // namespace mfot::service
