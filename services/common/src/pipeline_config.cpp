#include "mfot/service/pipeline_config.hpp"

#include <algorithm>
#include <numbers>
#include <string>
#include <thread>
#include <vector>

#include "mfot/service/convert.hpp"
#include "mfot/service/options.hpp"

namespace mfot::service {

namespace {

constexpr float kRadiansPerDegree = std::numbers::pi_v<float> / 180.f;
Eigen::Vector3f vector3(const std::vector<double>& v) {
  return Eigen::Vector3f(static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2]));
}

// preprocess.threads and merger.threads 0: a quarter of the cores, at least 1 and at most 8. The group's
// other processes (trackers, capture) need the rest; results are the same for any count.
int auto_threads() {
  const unsigned cores = std::thread::hardware_concurrency();
  return static_cast<int>(std::clamp(cores / 4, 1u, 8u));
}

// The tracker key that the merger shares: the JCSD cell (its re-identification registration), read the same
// way, with the same range, by both loaders.
float read_cell_size(ConfigSection& tracker) { return read_option<float>(tracker, "cell_size"); }

// The method's constants where the core's option structs keep the thesis (a feature off, or its value):
// the services run these (docs/method.md, "Constants"). Every other constant of the method is its
// option struct's default.
constexpr float kIcpMinPairedShare = 0.8f;           // fewer scored points paired: the estimate stays
constexpr float kIcpAnchorWeight = 4.f;              // the model's first-view points' weight in ICP's fit
constexpr float kIcpColorWeight = 1.f;               // ICP pairs in colour and space (coloured ICP)
constexpr float kConfidenceSeenThroughWeight = 2.f;  // confidence x (1 - this x the share seen through)
constexpr float kHoldMinScoredShare = 0.2f;          // fewer scored points than this share of the model: hold
constexpr float kReidentifyGrownMinShare = 0.5f;     // a grown object is matched once it holds this of the model
constexpr float kNewObjectHeldMargin = 0.02f;        // unexplained points this near a held object's box are its own
constexpr int kEnteringFrames = 10;                  // a cluster found this soon after an object entered the view ...
constexpr float kEnteringDistance = 0.08f;           // ... and this near it enters with it: a part of it
constexpr float kReidentifyUnseenRadiusRatio = 2.f;  // a view of an object lies within its diameter (2 x its radius)
constexpr float kSplitMinDeparture = 0.03f;          // a part splits off once it departed this far
constexpr float kRefitMinRotationDeg = 0.5f;         // a refit part turned less (and moved less) stays
constexpr int kDiscoveryConfirmFrames = 15;          // the discovery is confirmed over an object's first frames
constexpr float kPartBoundaryRadius = 0.03f;         // points this near another discovered part may move to it
constexpr int kJoinFrames = 15;                      // frames objects born together move as one before they join
constexpr int kOverlapJoinFrames = 5;                // frames two objects share one space before they are one
constexpr int kSplitFrames = 5;                      // frames an object lies in parts before it splits
constexpr int kCarryFrames = 10;                     // frames a hidden object moved with its carrier before
constexpr float kCarrySeenThroughShare = 0.2f;       // a hidden object's held place seen through: gripped away
constexpr float kCompanionContactDistance = 0.02f;   // models this close touch: a companion's motion is followed
constexpr float kRefitIcpMinPairedShare = 0.8f;
constexpr float kRefitIcpMaxRotationDeg = 10.f;
constexpr int kRefitIcpMaxPoints = 1000;
// The tracking step's (docs/method.md, "Constants"; the trackers and the merger share the hold's share and the claim
// radius: a hidden object's frames do not count towards its retirement, and each model carries what the other objects
// claim inside its tracker's hypothesis box).
constexpr float kHoldOccludedShare = 0.6f;            // this share of the model occluded: hold (the object is hidden)
constexpr float kClaimRadius = 0.01f;                 // a point this near another object's model is claimed by it
constexpr float kCompanionFraction = 0.5f;            // of the unpredicted particles, moved by a companion's motion
constexpr float kFollowReplacedEstimate = 1.f;        // the particle set moves by this share of a refinement
constexpr int kIcpMaxPoints = 2000;                   // ICP on at most this many scored points
constexpr float kLastPoseCheckOccludedShare = 0.15f;  // this share occluded: the last (or companion's) pose checked
constexpr float kCompanionTurnMinDeg = 0.7f;          // a companion turning this much: step 5e
constexpr float kPredictedStartMinTurnDeg = 1.f;      // the prediction this far from the estimate: step 5f ...
constexpr float kPredictedStartMinShift = 0.002f;     // ... or this far

}  // namespace

PreprocessConfig load_preprocess_config(const YAML::Node& root) {
  PreprocessConfig config;
  PreprocessorOptions& o = config.preprocessor;
  auto s = config_section(root, "preprocess");
  o.crop_min = vector3(read_list(s, "crop_min"));
  o.crop_max = vector3(read_list(s, "crop_max"));
  o.remove_plane = read_option<bool>(s, "remove_plane");
  o.plane_fit.iterations = read_option<int>(s, "ransac_iterations");
  o.plane_fit.sample_points = read_option<int>(s, "ransac_sample_points");
  o.plane_fit.inlier_distance = read_option<float>(s, "plane_inlier_distance");
  o.plane_fit.min_inlier_share = read_option<float>(s, "plane_min_inlier_share");
  o.plane_fit.seed = read_option<std::uint64_t>(s, "seed");
  o.plane_margin = read_option<float>(s, "plane_margin");
  o.plane_margin_sigmas = read_option<float>(s, "plane_margin_sigmas");
  const auto sigma = read_list(s, "depth_sigma");
  o.depth_sigma =
      Eigen::Vector3f(static_cast<float>(sigma[0]), static_cast<float>(sigma[1]), static_cast<float>(sigma[2]));
  o.table_prism = read_option<bool>(s, "table_prism");
  o.prism_min_share = read_option<float>(s, "prism_min_share");
  o.plane_keep_ratio = read_option<float>(s, "plane_keep_ratio");
  o.voxel_size = read_option<float>(s, "voxel_size");
  o.voxel_jitter = read_option<bool>(s, "voxel_jitter");
  o.voxel_jitter_seed = o.plane_fit.seed;
  o.cluster = read_option<bool>(s, "cluster");
  o.cluster_tolerance = read_option<float>(s, "cluster_tolerance");
  o.cluster_min_size = read_option<int>(s, "cluster_min_size");
  const int threads = read_option<int>(s, "threads");
  o.threads = threads > 0 ? threads : auto_threads();
  config.queue_frames = read_option<int>(s, "queue_frames");
  s.finish();
  try {
    o.validate();  // cross-field rules: crop_min < crop_max
  } catch (const std::invalid_argument& e) {
    throw ConfigError(std::string("preprocess: ") + e.what());
  }
  return config;
}

TrackerConfig load_tracker_config(const YAML::Node& root) {
  TrackerConfig c;
  auto s = config_section(root, "tracker");
  c.likelihood.backend = parse_likelihood_backend(read_choice(s, "backend"));
  c.likelihood.cpu_threads = read_option<int>(s, "threads");
  c.likelihood.cuda_device = read_option<int>(s, "cuda_device");
  c.likelihood.grid.cell_size = read_cell_size(s);
  c.filter.num_particles = read_option<int>(s, "particles");
  c.filter.lambda = read_option<float>(s, "lambda");
  c.filter.seed = read_option<std::uint64_t>(s, "seed");
  const std::string resampling = read_choice(s, "resampling");
  c.filter.resampling = resampling == "systematic" ? ResamplingScheme::kSystematic : ResamplingScheme::kMultinomial;
  const auto sigma = read_list(s, "init_sigma");
  for (int i = 0; i < 6; ++i) c.filter.init_sigma[i] = static_cast<float>(sigma[static_cast<std::size_t>(i)]);
  c.filter.a = read_option<float>(s, "diffusion_a");
  c.filter.b = read_option<float>(s, "diffusion_b");
  c.filter.predicted_fraction = read_option<float>(s, "predicted_fraction");
  c.filter.companion_fraction = kCompanionFraction;
  c.filter.follow_replaced_estimate = kFollowReplacedEstimate;
  c.step.hold_occluded_share = kHoldOccludedShare;
  c.step.max_hold_frames = read_option<int>(s, "max_hold_frames");
  c.step.hold_min_scored_share = kHoldMinScoredShare;
  c.step.confidence_seen_through_weight = kConfidenceSeenThroughWeight;
  c.step.exclude_claimed_radius = kClaimRadius;
  c.step.icp.iterations = read_option<int>(s, "icp_iterations");
  c.step.icp.max_distance = read_option<float>(s, "icp_max_distance");
  c.step.icp.min_paired_share = kIcpMinPairedShare;
  c.step.icp.max_points = kIcpMaxPoints;
  c.step.icp.anchor_weight = kIcpAnchorWeight;
  c.step.icp.color_weight = kIcpColorWeight;
  c.step.last_pose_check_occluded_share = kLastPoseCheckOccludedShare;
  c.step.companion_turn_min = kCompanionTurnMinDeg * kRadiansPerDegree;
  c.step.predicted_start_min_turn = kPredictedStartMinTurnDeg * kRadiansPerDegree;
  c.step.predicted_start_min_shift = kPredictedStartMinShift;
  c.heartbeat_ms = read_option<int>(s, "heartbeat_ms");
  c.merger_timeout_ms = read_option<int>(s, "merger_timeout_ms");
  c.scenes.max_scenes = read_option<std::size_t>(s, "queue_scenes");
  c.scenes.model_wait = std::chrono::milliseconds(read_option<int>(s, "model_wait_ms"));
  s.finish();
  try {
    const ParticleFilter validate_only(c.filter);  // the filter and the step validate their options
    c.step.validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(std::string("tracker: ") + e.what());
  }
  return c;
}

MergerConfig load_merger_config(const YAML::Node& root) {
  MergerConfig c;
  auto s = config_section(root, "merger");
  c.manager.segmentation.tau = read_option<float>(s, "tau");
  c.manager.model_update.alpha = read_option<float>(s, "alpha");
  c.manager.model_update.seed = read_option<std::uint64_t>(s, "seed");
  c.manager.min_object_points = read_option<std::size_t>(s, "min_object_points");
  c.manager.max_model_points = read_option<std::size_t>(s, "max_model_points");
  c.manager.growth_frames = read_option<int>(s, "growth_frames");
  c.manager.propagation_radius = read_option<float>(s, "propagation_radius");
  c.manager.propagation_min_seed_share = read_option<float>(s, "propagation_min_seed_share");
  c.manager.reidentify_frames = read_option<int>(s, "reidentify_frames");
  c.manager.reidentify_similarity = read_option<float>(s, "reidentify_similarity");
  c.manager.reidentify_grown_min_share = kReidentifyGrownMinShare;
  c.manager.reidentify_unseen_radius_ratio = kReidentifyUnseenRadiusRatio;
  c.manager.registration.seed = c.manager.model_update.seed;
  {
    // The registration scores like the trackers: their JCSD cell.
    auto tracker = config_section(root, "tracker");
    c.manager.registration.cell_size = read_cell_size(tracker);
    // A hidden object's frames (as the trackers' hold measures it) do not count towards its retirement.
    c.manager.hidden_occluded_share = kHoldOccludedShare;
    // Each model carries what the other objects claim inside its tracker's hypothesis box.
    TrackingStepOptions step;
    step.exclude_claimed_radius = kClaimRadius;
    c.claimed_margin = step.claimed_margin();
  }
  c.manager.new_objects.confirm_frames = read_option<int>(s, "new_object_frames");
  c.manager.support.min_points = read_option<std::size_t>(s, "retire_min_points");
  c.manager.support.max_frames = read_option<int>(s, "retire_frames");
  c.manager.held_birth_margin = kNewObjectHeldMargin;
  c.manager.entering_frames = kEnteringFrames;
  c.manager.entering_distance = kEnteringDistance;
  c.estimate_timeout_ms = read_option<int>(s, "estimate_timeout_ms");
  c.worker_timeout_ms = read_option<int>(s, "worker_timeout_ms");
  c.expected_workers = read_option<int>(s, "expected_workers");
  c.startup_timeout_ms = read_option<int>(s, "startup_timeout_ms");
  c.resume_listen_ms = read_option<int>(s, "resume_listen_ms");
  c.resume_timeout_ms = read_option<int>(s, "resume_timeout_ms");
  c.write_labels = read_option<bool>(s, "write_labels");
  c.fitting_distance = read_option<bool>(s, "fitting_distance");
  const int threads = read_option<int>(s, "threads");
  c.threads = threads > 0 ? threads : auto_threads();
  auto discovery = s.section("discovery");
  c.manager.discovery.method = DiscoveryMethod::kLccp;
  c.manager.discovery.seed_resolution = read_option<float>(discovery, "seed_resolution");
  c.manager.discovery.color_cut = read_option<float>(discovery, "color_cut");
  c.manager.discovery.min_part_points = read_option<int>(discovery, "min_part_points");
  c.manager.discovery.confirm_frames = kDiscoveryConfirmFrames;
  c.manager.discovery.boundary.radius = kPartBoundaryRadius;
  discovery.finish();
  auto& js = c.manager.join_split;
  js.join_frames = kJoinFrames;
  js.split_frames = kSplitFrames;
  js.overlap_frames = kOverlapJoinFrames;
  js.split_min_departure = kSplitMinDeparture;
  c.manager.carry.frames = kCarryFrames;
  c.manager.carry.seen_through_share = kCarrySeenThroughShare;
  c.manager.companion.contact_distance = kCompanionContactDistance;
  c.manager.refit.min_rotation = kRefitMinRotationDeg * kRadiansPerDegree;
  c.manager.refit.icp.min_paired_share = kRefitIcpMinPairedShare;
  c.manager.refit.icp.max_rotation = kRefitIcpMaxRotationDeg * kRadiansPerDegree;
  c.manager.refit.icp.max_points = kRefitIcpMaxPoints;
  auto world = s.section("world");
  const auto t = read_list(world, "translation");
  const auto q = read_list(world, "rotation");
  double tq[3] = {t[0], t[1], t[2]};
  double qq[4] = {q[0], q[1], q[2], q[3]};
  if (auto error = pose_from_arrays(tq, qq, c.world_from_camera)) {
    throw ConfigError("merger.world: " + *error + " (rotation is w, x, y, z)");
  }
  world.finish();
  s.finish();
  try {
    c.manager.validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(std::string("merger: ") + e.what());
  }
  return c;
}

}  // namespace mfot::service
