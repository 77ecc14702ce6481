#include "mfot/service/pipeline_config.hpp"

#include "mfot/service/convert.hpp"

#include <algorithm>
#include <numbers>
#include <string>
#include <thread>
#include <vector>

namespace mfot::service {

namespace {

constexpr float kRadiansPerDegree = std::numbers::pi_v<float> / 180.f;
Eigen::Vector3f vector3(const std::vector<double>& v) {
  return Eigen::Vector3f(static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2]));
}

// preprocess.threads 0: a quarter of the cores, at least 1 and at most 8. The group's other
// processes (trackers, merger, capture) need the rest; results are the same for any count.
int auto_preprocess_threads() {
  const unsigned cores = std::thread::hardware_concurrency();
  return static_cast<int>(std::clamp(cores / 4, 1u, 8u));
}

// The tracker keys that the merger shares: the JCSD cell and the confidence measure (its
// re-identification registration), the hypothesis margin and the claim radius (what it sends with
// each model), and the two settings carry mode needs off; read the same way, with the same ranges, by
// both loaders.
float read_cell_size(ConfigSection& tracker) { return tracker.get<float>("cell_size", 0.001f, 0.2f); }

float read_hypothesis_margin(ConfigSection& tracker) { return tracker.get<float>("hypothesis_margin", 0.f, 1.f); }
float read_claim_radius(ConfigSection& tracker) { return tracker.get<float>("exclude_claimed_radius", 0.f, 0.1f); }
float read_last_pose_check_share(ConfigSection& tracker) {
  return tracker.get<float>("last_pose_check_occluded_share", 0.f, 1.f);
}
float read_particles_follow(ConfigSection& tracker) {
  return tracker.get<float>("particles_follow_refinement", 0.f, 1.f);
}

EstimateFitOptions read_fit_options(ConfigSection& tracker) {
  EstimateFitOptions fit;
  fit.match_distance = tracker.get<float>("confidence_match_distance", 1e-4f, 0.1f);
  fit.claim_margin = tracker.get<float>("confidence_claim_margin", 0.f, 0.1f);
  fit.min_claimed_points = tracker.get<int>("confidence_min_points", 1, 1000000);
  return fit;
}

}  // namespace

PreprocessConfig load_preprocess_config(const YAML::Node& root) {
  PreprocessConfig config;
  PreprocessorOptions& o = config.preprocessor;
  auto s = config_section(root, "preprocess");
  o.crop_min = vector3(s.get_vector("crop_min", 3));
  o.crop_max = vector3(s.get_vector("crop_max", 3));
  o.remove_plane = s.get<bool>("remove_plane");
  o.plane_fit.iterations = s.get<int>("ransac_iterations", 1, 100000);
  o.plane_fit.sample_points = s.get<int>("ransac_sample_points", 3, 1000000);
  o.plane_fit.inlier_distance = s.get<float>("plane_inlier_distance", 1e-4f, 0.5f);
  o.plane_fit.min_inlier_share = s.get<float>("plane_min_inlier_share", 1e-3f, 1.f);
  o.plane_fit.seed = s.get<std::uint64_t>("seed");
  o.plane_margin = s.get<float>("plane_margin", 0.f, 0.5f);
  o.plane_margin_sigmas = s.get<float>("plane_margin_sigmas", 0.f, 10.f);
  const auto sigma = s.get_vector("depth_sigma", 3);
  o.depth_sigma = Eigen::Vector3f(static_cast<float>(sigma[0]), static_cast<float>(sigma[1]), static_cast<float>(sigma[2]));
  o.table_prism = s.get<bool>("table_prism");
  o.prism_min_share = s.get<float>("prism_min_share", 0.001f, 1.f);
  o.plane_keep_ratio = s.get<float>("plane_keep_ratio", 1e-3f, 1.f);
  o.voxel_size = s.get<float>("voxel_size", 1e-4f, 1.f);
  o.voxel_jitter = s.get<bool>("voxel_jitter");
  o.voxel_jitter_seed = o.plane_fit.seed;
  o.cluster = s.get<bool>("cluster");
  o.cluster_tolerance = s.get<float>("cluster_tolerance", 1e-4f, 1.f);
  o.cluster_min_size = s.get<int>("cluster_min_size", 1, 10000000);
  o.cluster_max_size = s.get<int>("cluster_max_size", 1, 10000000);
  const int threads = s.get<int>("threads", 0, 64);
  o.threads = threads > 0 ? threads : auto_preprocess_threads();
  config.queue_frames = s.get<int>("queue_frames", 1, 64);
  s.finish();
  try {
    o.validate();  // cross-field rules: crop_min < crop_max, cluster_min_size <= cluster_max_size
  } catch (const std::invalid_argument& e) {
    throw ConfigError(std::string("preprocess: ") + e.what());
  }
  return config;
}

TrackerConfig load_tracker_config(const YAML::Node& root) {
  TrackerConfig c;
  auto s = config_section(root, "tracker");
  c.likelihood.backend = parse_likelihood_backend(s.choice("backend", {"auto", "cuda", "cpu", "point-to-point"}));
  c.likelihood.cpu_threads = s.get<int>("threads", 1, 256);
  c.likelihood.cuda_device = s.get<int>("cuda_device", 0, 64);
  c.likelihood.grid.cell_size = read_cell_size(s);
  c.filter.num_particles = s.get<int>("particles", 1, 100000);
  c.filter.lambda = s.get<float>("lambda", 0.f, 1000.f);
  c.filter.seed = s.get<std::uint64_t>("seed");
  const std::string resampling = s.choice("resampling", {"multinomial", "systematic"});
  c.filter.resampling = resampling == "systematic" ? ResamplingScheme::kSystematic : ResamplingScheme::kMultinomial;
  const auto sigma = s.get_vector("init_sigma", 6);
  for (int i = 0; i < 6; ++i) c.filter.init_sigma[i] = static_cast<float>(sigma[static_cast<std::size_t>(i)]);
  c.filter.a = s.get<float>("diffusion_a", 0.f, 100.f);
  c.filter.b = s.get<float>("diffusion_b", 0.f, 100.f);
  c.filter.predicted_fraction = s.get<float>("predicted_fraction", 0.f, 1.f);
  c.filter.companion_fraction = s.get<float>("companion_fraction", 0.f, 1.f);
  c.filter.follow_replaced_estimate = read_particles_follow(s);
  c.filter.anneal_iterations = s.get<int>("anneal_iterations", 1, 10);
  c.filter.anneal_shrink = s.get<float>("anneal_shrink", 0.01f, 1.f);
  c.filter.refine_rounds = s.get<int>("refine_rounds", 0, 20);
  c.filter.refine_translation = s.get<float>("refine_translation", 0.f, 0.1f);
  c.filter.refine_rotation = s.get<float>("refine_rotation", 0.f, 0.5f);
  c.step.hypothesis.margin = read_hypothesis_margin(s);
  c.step.hold_occluded_share = s.get<float>("hold_occluded_share", 0.f, 1.f);
  c.step.max_hold_frames = s.get<int>("max_hold_frames", 1, 100000);
  c.step.hold_min_scored_share = s.get<float>("hold_min_scored_share", 0.f, 1.f);
  c.step.exclude_occluders = s.get<bool>("exclude_occluders");
  c.step.occlusion.depth_margin = s.get<float>("occluder_depth_margin", 0.f, 1.f);
  c.step.occlusion.window = s.get<float>("occlusion_window", 1e-4f, 0.1f);
  c.step.occlusion.own_surface_radius =
      s.get<float>("own_surface_radius", 0.f, 0.1f);
  c.step.fit = read_fit_options(s);
  c.step.hold_confidence_half_life = s.get<float>("confidence_hold_half_life", 1.f, 100000.f);
  c.step.confidence_seen_through_weight = s.get<float>("confidence_seen_through_weight", 0.f, 100.f);
  c.step.exclude_claimed_radius = read_claim_radius(s);
  c.step.follow_isolated = s.get<bool>("follow_isolated");
  c.step.isolated_motion.predicted_fraction = s.get<float>("isolated_predicted_fraction", 0.f, 1.f);
  c.step.isolated_motion.refine_rounds = s.get<int>("isolated_refine_rounds", 0, 20);
  c.step.icp.iterations = s.get<int>("icp_iterations", 0, 50);
  c.step.icp.max_distance = s.get<float>("icp_max_distance", 1e-4f, 0.1f);
  c.step.isolated_icp_max_distance = s.get<float>("isolated_icp_max_distance", 0.f, 0.1f);
  c.step.icp.min_paired_share = s.get<float>("icp_min_paired_share", 0.f, 1.f);
  c.step.icp.max_translation = s.get<float>("icp_max_translation", 0.f, 1.f);
  c.step.icp.max_rotation = s.get<float>("icp_max_rotation", 0.f, 3.14159f);
  c.step.icp.max_points = s.get<int>("icp_max_points", 3, 1000000);
  c.step.icp.final_iterations = s.get<int>("icp_final_iterations", 0, 50);
  c.step.icp.final_points = s.get<int>("icp_final_points", 3, 1000000);
  c.step.icp.anchor_weight = s.get<float>("icp_anchor_weight", 1.f, 1000.f);
  c.step.last_pose_check_occluded_share = read_last_pose_check_share(s);
  c.step.last_pose_check_points = s.get<int>("last_pose_check_points", 3, 1000000);
  c.step.last_pose_check_margin = s.get<float>("last_pose_check_margin", 0.f, 0.99f);
  c.step.companion_pose_check = s.get<bool>("companion_pose_check");
  c.step.companion_turn_min = s.get<float>("companion_turn_min_deg", 0.f, 180.f) * kRadiansPerDegree;
  c.step.companion_turn_min_cosine = s.get<float>("companion_turn_min_cosine", -1.f, 1.f);
  c.step.companion_turn_max_kept = s.get<float>("companion_turn_max_kept", 0.f, 1.f);
  c.heartbeat_ms = s.get<int>("heartbeat_ms", 10, 10000);
  c.merger_timeout_ms = s.get<int>("merger_timeout_ms", 100, 600000);
  c.scenes.max_scenes = s.get<std::size_t>("queue_scenes", 1, 64);
  c.scenes.model_wait =
      std::chrono::milliseconds(s.get<int>("model_wait_ms", 1, 600000));
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
  c.manager.segmentation.tau = s.get<float>("tau", 1e-4f, 0.1f);
  c.manager.model_update.alpha = s.get<float>("alpha", 0.f, 1.f);
  c.manager.model_update.seen_radius = s.get<float>("seen_radius", 0.f, 0.1f);
  c.manager.model_update.seed = s.get<std::uint64_t>("seed");
  c.manager.min_object_points = s.get<std::size_t>("min_object_points", 1, 100000);
  c.manager.max_model_points = s.get<std::size_t>("max_model_points", 1, 100000);
  c.manager.growth_frames = s.get<int>("growth_frames", 0, 100000);
  c.manager.propagation_radius = s.get<float>("propagation_radius", 0.f, 0.1f);
  c.manager.propagation_min_seed_share = s.get<float>("propagation_min_seed_share", 0.f, 1.f);
  c.manager.reidentify_frames = s.get<int>("reidentify_frames", 0, 1000000);
  c.manager.reidentify_similarity = s.get<float>("reidentify_similarity", 1e-3f, 1.f);
  c.manager.reidentify_register = s.get<bool>("reidentify_register");
  c.manager.reidentify_grown = s.get<bool>("reidentify_grown");
  c.manager.reidentify_grown_min_share = s.get<float>("reidentify_grown_min_share", 0.f, 1.f);
  c.manager.registration.rotations = s.get<int>("reidentify_rotations", 1, 100000);
  c.manager.registration.candidates = s.get<int>("reidentify_candidates", 1, 64);
  c.manager.registration.refine_rounds = s.get<int>("reidentify_refine_rounds", 0, 100);
  c.manager.registration.min_fit = s.get<float>("reidentify_min_fit", 0.f, 1.f);
  c.manager.registration.seed = c.manager.model_update.seed;
  {
    // The registration scores and checks like the trackers: their JCSD cell and confidence.
    auto tracker = config_section(root, "tracker");
    c.manager.registration.cell_size = read_cell_size(tracker);
    c.manager.registration.fit = read_fit_options(tracker);
    // Each model carries what the other objects claim inside its tracker's hypothesis box.
    TrackingStepOptions step;
    step.hypothesis.margin = read_hypothesis_margin(tracker);
    step.exclude_claimed_radius = read_claim_radius(tracker);
    c.claimed_margin = step.claimed_margin();
  }
  c.manager.new_objects.confirm_frames = s.get<int>("new_object_frames", 1, 1000);
  c.manager.new_objects.min_unassigned_share = s.get<float>("new_object_unassigned_share", 0.01f, 1.f);
  c.manager.support.min_points = s.get<std::size_t>("retire_min_points", 0, 100000);
  c.manager.support.max_frames = s.get<int>("retire_frames", 1, 10000);
  c.manager.hidden_occluded_share =
      s.get<float>("hidden_occluded_share", 0.f, 1.f);
  c.manager.held_birth_margin = s.get<float>("new_object_held_margin", 0.f, 0.5f);
  c.manager.occlusion.depth_margin =
      s.get<float>("hidden_depth_margin", 0.f, 1.f);
  c.estimate_timeout_ms = s.get<int>("estimate_timeout_ms", 1, 600000);
  c.worker_timeout_ms = s.get<int>("worker_timeout_ms", 100, 600000);
  c.expected_workers = s.get<int>("expected_workers", 0, 1000);
  c.startup_timeout_ms = s.get<int>("startup_timeout_ms", 0, 600000);
  c.write_labels = s.get<bool>("write_labels");
  c.fitting_distance = s.get<bool>("fitting_distance");
  c.fps = s.get<float>("fps", 1.f, 1000.f);
  auto discovery = s.section("discovery");
  try {
    c.manager.discovery.method = parse_discovery_method(discovery.get<std::string>("method"));
  } catch (const std::invalid_argument& e) {
    throw ConfigError("merger.discovery.method: " + std::string(e.what()));
  }
  c.manager.discovery.voxel_resolution = discovery.get<float>("voxel_resolution", 1e-4f, 0.1f);
  c.manager.discovery.seed_resolution = discovery.get<float>("seed_resolution", 1e-4f, 0.5f);
  c.manager.discovery.color_importance = discovery.get<float>("color_importance", 0.f, 100.f);
  c.manager.discovery.spatial_importance = discovery.get<float>("spatial_importance", 0.f, 100.f);
  c.manager.discovery.normal_importance = discovery.get<float>("normal_importance", 0.f, 100.f);
  c.manager.discovery.concavity_tolerance_deg = discovery.get<float>("concavity_tolerance_deg", 0.1f, 90.f);
  c.manager.discovery.smoothness_threshold = discovery.get<float>("smoothness_threshold", 0.f, 1.f);
  c.manager.discovery.extended_convexity = discovery.get<bool>("extended_convexity");
  c.manager.discovery.sanity_criterion = discovery.get<bool>("sanity_criterion");
  c.manager.discovery.min_part_points = discovery.get<int>("min_part_points", 1, 100000);
  c.manager.discovery.confirm_frames = discovery.get<int>("confirm_frames", 0, 1000);
  c.manager.discovery.confirm_votes = discovery.get<int>("confirm_votes", 1, 1000);
  c.manager.discovery.confirm_max_motion = discovery.get<float>("confirm_max_motion", 1e-4f, 1.f);
  c.manager.discovery.confirm_join = discovery.get<bool>("confirm_join");
  c.manager.discovery.boundary.radius = discovery.get<float>("boundary_radius", 0.f, 0.2f);
  c.manager.discovery.boundary.min_color_ratio = discovery.get<float>("boundary_color_ratio", 1.001f, 1e6f);
  discovery.finish();
  auto& js = c.manager.join_split;
  js.join_frames = s.get<int>("join_frames", 0, 10000);
  js.join_translation = s.get<float>("join_translation", 1e-4f, 0.1f);
  js.join_rotation_deg = s.get<float>("join_rotation_deg", 0.1f, 45.f);
  js.join_min_motion = s.get<float>("join_min_motion", 1e-3f, 1.f);
  js.join_min_turn_deg = s.get<float>("join_min_turn_deg", 0.1f, 180.f);
  js.join_contact_distance = s.get<float>("join_contact_distance", 1e-3f, 0.1f);
  js.split_frames = s.get<int>("split_frames", 0, 10000);
  js.split_min_share = s.get<float>("split_min_share", 0.01f, 0.5f);
  js.split_min_gap = s.get<float>("split_min_gap", 0.f, 1.f);
  js.split_max_occluded = s.get<float>("split_max_occluded", 0.f, 1.f);
  js.split_min_departure = s.get<float>("split_min_departure", 0.f, 1.f);
  auto carry = s.section("carry");
  c.manager.carry.frames = carry.get<int>("frames", 0, 10000);
  c.manager.carry.translation = carry.get<float>("translation", 1e-4f, 0.5f);
  c.manager.carry.rotation_deg = carry.get<float>("rotation_deg", 0.1f, 90.f);
  c.manager.carry.min_motion = carry.get<float>("min_motion", 1e-3f, 1.f);
  c.manager.carry.min_turn_deg = carry.get<float>("min_turn_deg", 0.1f, 180.f);
  c.manager.carry.contact_distance = carry.get<float>("contact_distance", 1e-3f, 0.1f);
  c.manager.carry.seen_through_share = carry.get<float>("seen_through_share", 0.f, 1.f);
  c.manager.carry.carried_seen_through_share = carry.get<float>("carried_seen_through_share", 0.f, 1.f);
  c.manager.carry.gripped_away = carry.choice("gripped_away", {"carry", "retire"}) == "retire"
                                     ? CarryOptions::GrippedAway::kRetire
                                     : CarryOptions::GrippedAway::kCarry;
  carry.finish();
  if (c.manager.carry.gripped_away == CarryOptions::GrippedAway::kCarry) {
    // Measured to lose the carried box (README "Carry mode and the trackers' settings"): refused here, where both
    // sections are in view, rather than discovered in a run.
    auto tracker = config_section(root, "tracker");
    std::vector<std::string> on;  // the settings that must be 0
    if (read_last_pose_check_share(tracker) > 0.f) on.push_back("tracker.last_pose_check_occluded_share > 0");
    if (read_particles_follow(tracker) > 0.f) on.push_back("tracker.particles_follow_refinement > 0");
    if (!on.empty()) {
      throw ConfigError("merger.carry.gripped_away: carry does not combine with " + on.front() +
                        (on.size() > 1 ? " or " + on.back() : "") + " (the carried box is lost): set " +
                        (on.size() > 1 ? "them" : "it") + " to 0, as configs/carry.yaml does");
    }
  }
  auto companion = s.section("companion");
  c.manager.companion.contact_distance = companion.get<float>("contact_distance", 0.f, 0.1f);
  c.manager.companion.min_motion = companion.get<float>("min_motion", 1e-4f, 1.f);
  c.manager.companion.min_turn_deg = companion.get<float>("min_turn_deg", 0.01f, 180.f);
  companion.finish();
  auto refit = s.section("refit");
  c.manager.refit.enabled = refit.get<bool>("enabled");
  c.manager.refit.min_points = refit.get<int>("min_points", 3, 1000000);
  c.manager.refit.min_spread = refit.get<float>("min_spread", 0.f, 1.f);
  c.manager.refit.min_coverage = refit.get<float>("min_coverage", 0.f, 1.f);
  c.manager.refit.min_rotation = refit.get<float>("min_rotation_deg", 0.f, 180.f) * kRadiansPerDegree;
  c.manager.refit.min_translation = refit.get<float>("min_translation", 0.f, 1.f);
  c.manager.refit.min_held_rotation = refit.get<float>("min_held_rotation", 0.f, 1.f);
  c.manager.refit.icp.iterations = refit.get<int>("icp_iterations", 1, 50);
  c.manager.refit.icp.max_distance = refit.get<float>("icp_max_distance", 1e-4f, 0.1f);
  c.manager.refit.icp.min_paired_share = refit.get<float>("icp_min_paired_share", 0.f, 1.f);
  c.manager.refit.icp.max_translation = refit.get<float>("icp_max_translation", 0.f, 1.f);
  c.manager.refit.icp.max_rotation = refit.get<float>("icp_max_rotation_deg", 0.f, 180.f) * kRadiansPerDegree;
  c.manager.refit.icp.max_points = refit.get<int>("icp_max_points", 3, 1000000);
  refit.finish();
  auto world = s.section("world");
  const auto t = world.get_vector("translation", 3);
  const auto q = world.get_vector("rotation", 4);
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
