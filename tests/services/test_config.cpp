#include "mfot/capture/capture_settings.hpp"
#include "mfot/service/config.hpp"
#include "mfot/service/pipeline_config.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

namespace mfot::service {
namespace {

ConfigSection section_of(const std::string& yaml, const std::string& name) {
  return config_section(YAML::Load(yaml), name);
}

// A config text laid over the built-in defaults, as load_config_file does.
YAML::Node with_defaults(const std::string& yaml) { return merged_over_defaults(YAML::Load(yaml)); }

// Loading yaml over the defaults with load (load_tracker_config or load_merger_config) throws a
// ConfigError whose message names key.
template <typename Load>
void expect_rejected(Load load, const std::string& yaml, const std::string& key) {
  try {
    (void)load(with_defaults(yaml));
    ADD_FAILURE() << yaml << " was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
  }
}

TEST(Config, ReadsValuesAndRefusesAMissingKey) {
  auto s = section_of("tracker:\n  particles: 200\n  alpha: 0.05\n  backend: cpu\n", "tracker");
  EXPECT_EQ(s.get<int>("particles", 1, 100000), 200);
  EXPECT_DOUBLE_EQ(s.get<double>("alpha", 0.0, 1.0), 0.05);
  EXPECT_EQ(s.choice("backend", {"auto", "cuda", "cpu"}), "cpu");
  try {
    s.get<int>("threads");
    FAIL() << "a missing key was read";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("tracker.threads: missing"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(s.finish());
}

TEST(Config, UnknownKeyIsRefusedWithItsName) {
  auto s = section_of("tracker:\n  particles: 200\n  partciles: 100\n", "tracker");
  s.get<int>("particles");
  try {
    s.finish();
    FAIL() << "unknown key accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("tracker.partciles"), std::string::npos) << e.what();
  }
}

TEST(Config, OutOfRangeNamesKeyAndRange) {
  auto s = section_of("merger:\n  alpha: 1.5\n", "merger");
  try {
    s.get<double>("alpha", 0.0, 1.0);
    FAIL() << "alpha > 1 accepted";
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("merger.alpha"), std::string::npos) << what;
    EXPECT_NE(what.find("[0.0"), std::string::npos) << what;
  }
  auto zero = section_of("tracker:\n  particles: 0\n", "tracker");
  EXPECT_THROW(zero.get<int>("particles", 1, 100000), ConfigError);
}

TEST(Config, WrongTypeIsRefused) {
  auto s = section_of("tracker:\n  particles: many\n", "tracker");
  try {
    s.get<int>("particles");
    FAIL() << "string accepted as integer";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("expected an integer"), std::string::npos) << e.what();
  }
}

TEST(Config, BadChoiceListsAllowedValues) {
  auto s = section_of("tracker:\n  backend: opencl\n", "tracker");
  try {
    s.choice("backend", {"auto", "cuda", "cpu"});
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("auto|cuda|cpu"), std::string::npos) << e.what();
  }
}

TEST(Config, NestedSectionsAndVectors) {
  auto root = YAML::Load("merger:\n  world:\n    translation: [0, 0, 1]\n    bogus: 1\n");
  auto merger = config_section(root, "merger");
  auto world = merger.section("world");
  const auto t = world.get_vector("translation", 3);
  EXPECT_DOUBLE_EQ(t[2], 1.0);
  EXPECT_THROW(world.get_vector("translation", 4), ConfigError);
  EXPECT_THROW(world.finish(), ConfigError);
  EXPECT_THROW(check_top_level(root, {"capture"}), ConfigError);
  EXPECT_NO_THROW(check_top_level(root, {"merger"}));
}

TEST(Config, TrackerOcclusionKeysReachTheTrackingStep) {
  const TrackerConfig c = load_tracker_config(with_defaults(
      "tracker:\n  hypothesis_margin: 0.04\n  exclude_occluders: true\n  hold_occluded_share: 0.7\n"
      "  occluder_depth_margin: 0.02\n  own_surface_radius: 0.005\n  occlusion_window: 0.01\n"
      "  hold_min_scored_share: 0.25\n"));
  EXPECT_FLOAT_EQ(c.step.hypothesis.margin, 0.04f);
  EXPECT_TRUE(c.step.exclude_occluders);
  EXPECT_FLOAT_EQ(c.step.hold_occluded_share, 0.7f);
  EXPECT_FLOAT_EQ(c.step.occlusion.depth_margin, 0.02f);
  EXPECT_FLOAT_EQ(c.step.occlusion.own_surface_radius, 0.005f);
  EXPECT_FLOAT_EQ(c.step.occlusion.window, 0.01f);
  EXPECT_FLOAT_EQ(c.step.hold_min_scored_share, 0.25f);
  // Absent keys: the shipped step (configs/default.yaml), not the option struct's thesis values.
  const TrackerConfig shipped = load_tracker_config(with_defaults("tracker:\n  particles: 50\n"));
  EXPECT_TRUE(shipped.step.exclude_occluders);
  EXPECT_FLOAT_EQ(shipped.step.hold_occluded_share, 0.6f);
  EXPECT_FLOAT_EQ(shipped.step.hold_min_scored_share, 0.2f);
  expect_rejected(load_tracker_config, "tracker:\n  occlusion_window: 0.5\n", "occlusion_window");
  EXPECT_THROW(load_tracker_config(with_defaults("tracker:\n  exclude_occluders: maybe\n")), ConfigError);
  expect_rejected(load_tracker_config, "tracker:\n  hold_min_scored_share: 2\n", "hold_min_scored_share");
}

TEST(Config, TheLastPoseCheckKeysReachTheStep) {
  const TrackerConfig c = load_tracker_config(with_defaults(
      "tracker:\n  last_pose_check_occluded_share: 0.3\n  last_pose_check_points: 250\n  last_pose_check_margin: 0.05\n"));
  EXPECT_FLOAT_EQ(c.step.last_pose_check_occluded_share, 0.3f);
  EXPECT_EQ(c.step.last_pose_check_points, 250);
  EXPECT_FLOAT_EQ(c.step.last_pose_check_margin, 0.05f);
  // Absent keys: the shipped check (configs/default.yaml), not the option struct's thesis value (off).
  const TrackerConfig shipped = load_tracker_config(with_defaults("tracker:\n  particles: 50\n"));
  EXPECT_GT(shipped.step.last_pose_check_occluded_share, 0.f);
  expect_rejected(load_tracker_config, "tracker:\n  last_pose_check_occluded_share: 1.5\n",
                  "last_pose_check_occluded_share");
  expect_rejected(load_tracker_config, "tracker:\n  last_pose_check_points: 2\n", "last_pose_check_points");
  expect_rejected(load_tracker_config, "tracker:\n  last_pose_check_margin: 1\n", "last_pose_check_margin");
  // The check needs the occluded share, which only the hold measures.
  EXPECT_THROW(load_tracker_config(with_defaults("tracker:\n  hold_occluded_share: 0\n")), ConfigError);
}

TEST(Config, TheConfidencesSeenThroughWeightReachesTheStep) {
  EXPECT_FLOAT_EQ(
      load_tracker_config(with_defaults("tracker:\n  confidence_seen_through_weight: 3\n")).step.confidence_seen_through_weight,
      3.f);
  // Absent: the shipped weight (configs/default.yaml), not the option struct's fit alone.
  EXPECT_GT(load_tracker_config(with_defaults("tracker:\n  particles: 50\n")).step.confidence_seen_through_weight, 0.f);
  expect_rejected(load_tracker_config, "tracker:\n  confidence_seen_through_weight: 101\n",
                  "confidence_seen_through_weight");
  expect_rejected(load_tracker_config, "tracker:\n  confidence_seen_through_weight: -1\n",
                  "confidence_seen_through_weight");
  // The share needs the scene's rays, which only the hold indexes: the thesis's step (no hold) needs the three off.
  const std::string hold_off = "tracker:\n  hold_occluded_share: 0\n  last_pose_check_occluded_share: 0\n";
  const std::string no_hold = hold_off + "  companion_pose_check: false\n";
  expect_rejected(load_tracker_config, no_hold, "confidence_seen_through_weight");
  expect_rejected(load_tracker_config, hold_off + "  confidence_seen_through_weight: 0\n", "companion_pose_check");
  EXPECT_NO_THROW(load_tracker_config(with_defaults(no_hold + "  confidence_seen_through_weight: 0\n")));
}

TEST(Config, TheCompanionPoseCheckKeyReachesTheStep) {
  EXPECT_FALSE(load_tracker_config(with_defaults("tracker:\n  companion_pose_check: false\n")).step.companion_pose_check);
  // Absent: the shipped value (configs/default.yaml: on).
  EXPECT_TRUE(load_tracker_config(with_defaults("tracker:\n  particles: 50\n")).step.companion_pose_check);
  EXPECT_THROW(load_tracker_config(with_defaults("tracker:\n  companion_pose_check: sometimes\n")), ConfigError);
}

TEST(Config, TheCompanionTurnKeysReachTheStep) {
  const TrackerConfig c = load_tracker_config(with_defaults(
      "tracker:\n  companion_turn_min_deg: 1.5\n  companion_turn_min_cosine: 0.6\n  companion_turn_max_kept: 0.4\n"));
  EXPECT_NEAR(c.step.companion_turn_min, 1.5f * std::numbers::pi_v<float> / 180.f, 1e-7f);
  EXPECT_FLOAT_EQ(c.step.companion_turn_min_cosine, 0.6f);
  EXPECT_FLOAT_EQ(c.step.companion_turn_max_kept, 0.4f);
  // Absent: the shipped step (configs/default.yaml: on), not the option struct's thesis value (off).
  EXPECT_GT(load_tracker_config(with_defaults("tracker:\n  particles: 50\n")).step.companion_turn_min, 0.f);
  expect_rejected(load_tracker_config, "tracker:\n  companion_turn_min_deg: -1\n", "companion_turn_min_deg");
  expect_rejected(load_tracker_config, "tracker:\n  companion_turn_min_cosine: 1.5\n", "companion_turn_min_cosine");
  expect_rejected(load_tracker_config, "tracker:\n  companion_turn_max_kept: 2\n", "companion_turn_max_kept");
}

TEST(Config, TheClaimRadiusReachesTheStepAndTheMergersModels) {
  const std::string keys = "tracker:\n  hypothesis_margin: 0.04\n  exclude_claimed_radius: 0.015\n";
  EXPECT_FLOAT_EQ(load_tracker_config(with_defaults(keys)).step.exclude_claimed_radius, 0.015f);
  // The merger sends with each model what lies within the tracker's margin plus the radius.
  EXPECT_FLOAT_EQ(load_merger_config(with_defaults(keys)).claimed_margin, 0.055f);
  EXPECT_FLOAT_EQ(load_merger_config(with_defaults("tracker:\n  exclude_claimed_radius: 0\n")).claimed_margin, 0.f);
  // Shipped: on (configs/default.yaml).
  EXPECT_GT(load_tracker_config(with_defaults("tracker:\n  particles: 50\n")).step.exclude_claimed_radius, 0.f);
  for (const std::string bad : {"tracker:\n  exclude_claimed_radius: 0.5\n", "tracker:\n  exclude_claimed_radius: -1\n"}) {
    try {
      load_tracker_config(with_defaults(bad));
      FAIL() << bad << " was accepted";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("exclude_claimed_radius"), std::string::npos) << e.what();
    }
    EXPECT_THROW(load_merger_config(with_defaults(bad)), ConfigError);
  }
}

TEST(Config, TheIsolatedMotionAndIcpKeysReachTheStep) {
  const TrackerConfig c = load_tracker_config(
      with_defaults("tracker:\n  follow_isolated: true\n  isolated_predicted_fraction: 0.9\n  isolated_refine_rounds: 4\n"));
  EXPECT_TRUE(c.step.follow_isolated);
  EXPECT_FLOAT_EQ(c.step.isolated_motion.predicted_fraction, 0.9f);
  EXPECT_EQ(c.step.isolated_motion.refine_rounds, 4);
  const TrackerConfig icp = load_tracker_config(with_defaults(
      "tracker:\n  icp_iterations: 7\n  icp_max_distance: 0.02\n  icp_min_paired_share: 0.4\n"
      "  icp_max_translation: 0.03\n  icp_max_rotation: 0.2\n  icp_max_points: 300\n  icp_final_iterations: 4\n"
      "  icp_final_points: 900\n  icp_anchor_weight: 7.5\n  isolated_icp_max_distance: 0.006\n"));
  EXPECT_EQ(icp.step.icp.iterations, 7);
  EXPECT_FLOAT_EQ(icp.step.icp.max_distance, 0.02f);
  EXPECT_FLOAT_EQ(icp.step.icp.min_paired_share, 0.4f);
  EXPECT_FLOAT_EQ(icp.step.icp.max_translation, 0.03f);
  EXPECT_FLOAT_EQ(icp.step.icp.max_rotation, 0.2f);
  EXPECT_EQ(icp.step.icp.max_points, 300);
  EXPECT_EQ(icp.step.icp.final_iterations, 4);
  EXPECT_EQ(icp.step.icp.final_points, 900);
  EXPECT_FLOAT_EQ(icp.step.icp.anchor_weight, 7.5f);
  EXPECT_FLOAT_EQ(icp.step.isolated_icp_max_distance, 0.006f);
  EXPECT_FALSE(load_tracker_config(with_defaults("tracker:\n  follow_isolated: false\n")).step.follow_isolated);
  // The thesis everywhere is one switch away; without the claims nothing tells an object is isolated.
  EXPECT_NO_THROW(load_tracker_config(with_defaults("tracker:\n  follow_isolated: false\n  exclude_claimed_radius: 0\n")));
  const std::pair<std::string, std::string> bad[] = {
      {"tracker:\n  follow_isolated: true\n  exclude_claimed_radius: 0\n", "follow_isolated"},
      {"tracker:\n  isolated_predicted_fraction: 1.5\n", "isolated_predicted_fraction"},
      {"tracker:\n  isolated_refine_rounds: 21\n", "isolated_refine_rounds"},
      {"tracker:\n  icp_iterations: 51\n", "icp_iterations"},
      {"tracker:\n  icp_max_distance: 0.5\n", "icp_max_distance"},
      {"tracker:\n  isolated_icp_max_distance: 0.2\n", "isolated_icp_max_distance"},
      {"tracker:\n  isolated_icp_max_distance: -0.001\n", "isolated_icp_max_distance"},
      {"tracker:\n  isolated_icp_max_distance: 0.00005\n", "isolated_icp_max_distance"},
      {"tracker:\n  icp_final_points: 2\n", "icp_final_points"},
      {"tracker:\n  icp_anchor_weight: 0.5\n", "icp_anchor_weight"},
      {"tracker:\n  icp_iterations: 3\n  icp_final_iterations: 4\n", "final_iterations"},
  };
  for (const auto& [yaml, key] : bad) expect_rejected(load_tracker_config, yaml, key);
}

TEST(Config, ConfidenceAndReregistrationKeysReachTheirOptions) {
  const std::string tracker =
      "tracker:\n  cell_size: 0.02\n  confidence_match_distance: 0.008\n  confidence_claim_margin: 0.005\n"
      "  confidence_min_points: 40\n  confidence_hold_half_life: 10\n";
  const TrackerConfig t = load_tracker_config(with_defaults(tracker));
  EXPECT_FLOAT_EQ(t.step.fit.match_distance, 0.008f);
  EXPECT_FLOAT_EQ(t.step.fit.claim_margin, 0.005f);
  EXPECT_EQ(t.step.fit.min_claimed_points, 40);
  EXPECT_FLOAT_EQ(t.step.hold_confidence_half_life, 10.f);
  const MergerConfig m = load_merger_config(with_defaults(
      tracker + "merger:\n  reidentify_register: false\n  reidentify_rotations: 64\n  reidentify_candidates: 2\n"
                "  reidentify_refine_rounds: 5\n  reidentify_min_fit: 0.6\n  reidentify_grown: false\n"));
  EXPECT_FALSE(m.manager.reidentify_register);
  EXPECT_FALSE(m.manager.reidentify_grown);
  EXPECT_TRUE(load_merger_config(with_defaults("")).manager.reidentify_grown);  // the shipped default
  EXPECT_FLOAT_EQ(
      load_merger_config(with_defaults("merger:\n  propagation_min_seed_share: 0.2\n")).manager.propagation_min_seed_share,
      0.2f);
  expect_rejected(load_merger_config, "merger:\n  propagation_min_seed_share: 1.5\n", "propagation_min_seed_share");
  // The shipped guard: a box the hand brings back is not swallowed by a few of the hand's points in its cluster.
  EXPECT_FLOAT_EQ(load_merger_config(with_defaults("")).manager.propagation_min_seed_share, 0.1f);
  EXPECT_FLOAT_EQ(
      load_merger_config(with_defaults("merger:\n  reidentify_grown_min_share: 0.3\n")).manager.reidentify_grown_min_share,
      0.3f);
  expect_rejected(load_merger_config, "merger:\n  reidentify_grown_min_share: -0.1\n", "reidentify_grown_min_share");
  EXPECT_EQ(m.manager.registration.rotations, 64);
  EXPECT_EQ(m.manager.registration.candidates, 2);
  EXPECT_EQ(m.manager.registration.refine_rounds, 5);
  EXPECT_FLOAT_EQ(m.manager.registration.min_fit, 0.6f);
  // The registration scores and checks like the trackers.
  EXPECT_FLOAT_EQ(m.manager.registration.cell_size, 0.02f);
  EXPECT_FLOAT_EQ(m.manager.registration.fit.match_distance, 0.008f);
  EXPECT_EQ(m.manager.registration.fit.min_claimed_points, 40);
  for (const std::string bad : {"tracker:\n  confidence_match_distance: 0.5\n", "merger:\n  reidentify_min_fit: 1.5\n",
                                "merger:\n  reidentify_rotations: 0\n"}) {
    const bool tracker_key = bad.rfind("tracker", 0) == 0;
    try {
      tracker_key ? (void)load_tracker_config(with_defaults(bad)) : (void)load_merger_config(with_defaults(bad));
      FAIL() << bad << " was accepted";
    } catch (const ConfigError& e) {
      const std::string key = bad.substr(bad.find("  ") + 2, bad.find(':', bad.find("  ")) - bad.find("  ") - 2);
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  }
}

TEST(Config, CarryKeysReachTheManager) {
  const MergerConfig m = load_merger_config(with_defaults(
      "merger:\n  carry:\n    frames: 7\n    translation: 0.02\n    rotation_deg: 12\n    min_motion: 0.05\n"
      "    min_turn_deg: 20\n    contact_distance: 0.015\n    seen_through_share: 0.35\n"
      "    carried_seen_through_share: 0.1\n    gripped_away: retire\n"));
  EXPECT_EQ(m.manager.carry.frames, 7);
  EXPECT_FLOAT_EQ(m.manager.carry.translation, 0.02f);
  EXPECT_FLOAT_EQ(m.manager.carry.rotation_deg, 12.f);
  EXPECT_FLOAT_EQ(m.manager.carry.min_motion, 0.05f);
  EXPECT_FLOAT_EQ(m.manager.carry.min_turn_deg, 20.f);
  EXPECT_FLOAT_EQ(m.manager.carry.contact_distance, 0.015f);
  EXPECT_FLOAT_EQ(m.manager.carry.seen_through_share, 0.35f);
  EXPECT_FLOAT_EQ(m.manager.carry.carried_seen_through_share, 0.1f);
  EXPECT_EQ(m.manager.carry.gripped_away, CarryOptions::GrippedAway::kRetire);
  EXPECT_EQ(load_merger_config(with_defaults("merger:\n  carry:\n    frames: 0\n")).manager.carry.frames, 0);
  for (const std::string key : {"frames: -1", "translation: 0", "rotation_deg: 100", "contact_distance: 0.5",
                                "seen_through_share: 1.5", "carried_seen_through_share: -0.1", "gripped_away: drop",
                                "speed: 1"}) {
    expect_rejected(load_merger_config, "merger:\n  carry:\n    " + key + "\n", key.substr(0, key.find(':')));
  }
}

TEST(Config, RefitKeysReachTheManager) {
  const MergerConfig m = load_merger_config(with_defaults(
      "merger:\n  refit:\n    enabled: false\n    min_points: 90\n    min_spread: 0.02\n    min_coverage: 0.6\n"
      "    min_rotation_deg: 1\n    min_translation: 0.003\n    min_held_rotation: 0.3\n    icp_iterations: 7\n"
      "    icp_max_distance: 0.008\n"
      "    icp_min_paired_share: 0.7\n    icp_max_translation: 0.015\n    icp_max_rotation_deg: 8\n"
      "    icp_max_points: 500\n"));
  const PartRefitOptions& r = m.manager.refit;
  EXPECT_FALSE(r.enabled);
  EXPECT_EQ(r.min_points, 90);
  EXPECT_FLOAT_EQ(r.min_spread, 0.02f);
  EXPECT_FLOAT_EQ(r.min_coverage, 0.6f);
  EXPECT_NEAR(r.min_rotation, 1.f * std::numbers::pi_v<float> / 180.f, 1e-7f);
  EXPECT_FLOAT_EQ(r.min_translation, 0.003f);
  EXPECT_FLOAT_EQ(r.min_held_rotation, 0.3f);
  EXPECT_EQ(r.icp.iterations, 7);
  EXPECT_FLOAT_EQ(r.icp.max_distance, 0.008f);
  EXPECT_FLOAT_EQ(r.icp.min_paired_share, 0.7f);
  EXPECT_FLOAT_EQ(r.icp.max_translation, 0.015f);
  EXPECT_NEAR(r.icp.max_rotation, 8.f * std::numbers::pi_v<float> / 180.f, 1e-6f);
  EXPECT_EQ(r.icp.max_points, 500);
  EXPECT_TRUE(load_merger_config(with_defaults("")).manager.refit.enabled);  // the shipped default
  for (const std::string key : {"min_points: 2", "min_spread: -0.1", "min_coverage: 1.5", "min_rotation_deg: 200",
                                "min_held_rotation: 1.5", "icp_iterations: 0", "icp_max_distance: 0",
                                "icp_max_points: 1", "gain: 1"}) {
    expect_rejected(load_merger_config, "merger:\n  refit:\n    " + key + "\n", key.substr(0, key.find(':')));
  }
}

TEST(Config, CarryModeIsRefusedWithTheTrackerSettingsItDoesNotCombineWith) {
  const std::string carry = "merger:\n  carry:\n    gripped_away: carry\n";
  // The defaults keep both on: each is named.
  expect_rejected(load_merger_config, carry, "tracker.last_pose_check_occluded_share");
  expect_rejected(load_merger_config, carry, "tracker.particles_follow_refinement");
  expect_rejected(load_merger_config, carry + "tracker:\n  last_pose_check_occluded_share: 0\n",
                  "tracker.particles_follow_refinement");
  expect_rejected(load_merger_config, carry + "tracker:\n  particles_follow_refinement: 0\n",
                  "tracker.last_pose_check_occluded_share");
  const MergerConfig both_off = load_merger_config(with_defaults(
      carry + "tracker:\n  last_pose_check_occluded_share: 0\n  particles_follow_refinement: 0\n"));
  EXPECT_EQ(both_off.manager.carry.gripped_away, CarryOptions::GrippedAway::kCarry);
  // The shipped overlay sets what carry mode needs, and the trackers load it too.
  const YAML::Node overlay = load_config_file(std::string(MFOT_SOURCE_DIR) + "/configs/carry.yaml");
  EXPECT_EQ(load_merger_config(overlay).manager.carry.gripped_away, CarryOptions::GrippedAway::kCarry);
  const TrackerConfig tracker = load_tracker_config(overlay);
  EXPECT_EQ(tracker.step.last_pose_check_occluded_share, 0.f);
  EXPECT_FALSE(tracker.step.companion_pose_check);
  EXPECT_EQ(tracker.filter.follow_replaced_estimate, 0.f);
}

TEST(Config, CompanionKeysReachTheManagerAndTheFilter) {
  const MergerConfig m = load_merger_config(with_defaults(
      "merger:\n  companion:\n    contact_distance: 0.015\n    min_motion: 0.004\n    min_turn_deg: 2\n"));
  EXPECT_FLOAT_EQ(m.manager.companion.contact_distance, 0.015f);
  EXPECT_FLOAT_EQ(m.manager.companion.min_motion, 0.004f);
  EXPECT_FLOAT_EQ(m.manager.companion.min_turn_deg, 2.f);
  EXPECT_EQ(load_merger_config(with_defaults("merger:\n  companion:\n    contact_distance: 0\n")).manager.companion.contact_distance, 0.f);
  EXPECT_FLOAT_EQ(load_tracker_config(with_defaults("tracker:\n  companion_fraction: 0.3\n")).filter.companion_fraction, 0.3f);
  for (const std::string key : {"contact_distance: 0.5", "min_motion: 0", "min_turn_deg: 181", "rate: 1"}) {
    expect_rejected(load_merger_config, "merger:\n  companion:\n    " + key + "\n", key.substr(0, key.find(':')));
  }
  expect_rejected(load_tracker_config, "tracker:\n  companion_fraction: 1.5\n", "companion_fraction");
}

TEST(Config, ParticlesFollowRefinementReachesTheFilter) {
  EXPECT_FLOAT_EQ(load_tracker_config(with_defaults("tracker:\n  particles_follow_refinement: 0.25\n"))
                      .filter.follow_replaced_estimate, 0.25f);
  EXPECT_EQ(load_tracker_config(with_defaults("tracker:\n  particles_follow_refinement: 0\n")).filter.follow_replaced_estimate,
            0.f);
  expect_rejected(load_tracker_config, "tracker:\n  particles_follow_refinement: 1.5\n", "particles_follow_refinement");
}

TEST(Config, VoxelJitterReachesThePreprocessorWithItsSeed) {
  const PreprocessConfig fixed = load_preprocess_config(with_defaults(""));
  EXPECT_FALSE(fixed.preprocessor.voxel_jitter);  // the shipped value: a fixed grid (thesis)
  const PreprocessConfig moving =
      load_preprocess_config(with_defaults("preprocess:\n  voxel_jitter: true\n  seed: 77\n"));
  EXPECT_TRUE(moving.preprocessor.voxel_jitter);
  EXPECT_EQ(moving.preprocessor.voxel_jitter_seed, 77u);
  EXPECT_EQ(moving.preprocessor.plane_fit.seed, 77u);
  expect_rejected(load_preprocess_config, "preprocess:\n  voxel_jitter: 3\n", "voxel_jitter");
}

TEST(Config, DiscoveryConfirmAndHeldBirthKeysReachTheManager) {
  const MergerConfig m = load_merger_config(with_defaults(
      "merger:\n  discovery:\n    confirm_frames: 20\n    confirm_votes: 4\n    confirm_max_motion: 0.02\n"));
  EXPECT_EQ(m.manager.discovery.confirm_frames, 20);
  EXPECT_EQ(m.manager.discovery.confirm_votes, 4);
  EXPECT_FLOAT_EQ(m.manager.discovery.confirm_max_motion, 0.02f);
  EXPECT_TRUE(m.manager.discovery.confirm_join);  // the shipped value
  // The shipped supervoxel size: 2 cm finds the step between touching front faces that 3 cm straddles
  // (LccpDiscoveryOnSensorViews).
  EXPECT_FLOAT_EQ(m.manager.discovery.seed_resolution, 0.02f);
  // The shipped colour cut: a synthetic pile's touching objects come apart (PileDiscovery).
  EXPECT_FLOAT_EQ(m.manager.discovery.color_cut, 0.f);
  EXPECT_FALSE(load_merger_config(with_defaults("merger:\n  discovery:\n    confirm_join: false\n")).manager.discovery.confirm_join);
  for (const std::string key : {"confirm_frames: -1", "confirm_votes: 0", "confirm_max_motion: 2", "confirm_join: 3", "color_cut: 201"}) {
    expect_rejected(load_merger_config, "merger:\n  discovery:\n    " + key + "\n", key.substr(0, key.find(':')));
  }
  EXPECT_FLOAT_EQ(load_merger_config(with_defaults("merger:\n  new_object_held_margin: 0.05\n")).manager.held_birth_margin, 0.05f);
  expect_rejected(load_merger_config, "merger:\n  new_object_held_margin: 0.6\n", "new_object_held_margin");
  // More votes than frames: the options' own check, named.
  expect_rejected(load_merger_config, "merger:\n  discovery:\n    confirm_frames: 2\n    confirm_votes: 3\n",
                  "confirm_votes");
}

TEST(Config, DiscoveryBoundaryKeysReachTheManager) {
  const MergerConfig m = load_merger_config(
      with_defaults("merger:\n  discovery:\n    boundary_radius: 0.02\n    boundary_color_ratio: 8\n"));
  EXPECT_FLOAT_EQ(m.manager.discovery.boundary.radius, 0.02f);
  EXPECT_FLOAT_EQ(m.manager.discovery.boundary.min_color_ratio, 8.f);
  for (const std::string key : {"boundary_radius: -0.01", "boundary_radius: 0.5", "boundary_color_ratio: 1"}) {
    expect_rejected(load_merger_config, "merger:\n  discovery:\n    " + key + "\n", key.substr(0, key.find(':')));
  }
}

TEST(Config, SplitDepartureReachesTheManager) {
  const MergerConfig m = load_merger_config(with_defaults("merger:\n  split_min_departure: 0.05\n"));
  EXPECT_FLOAT_EQ(m.manager.join_split.split_min_departure, 0.05f);
  expect_rejected(load_merger_config, "merger:\n  split_min_departure: -0.1\n", "split_min_departure");
}

TEST(Config, MissingFileAndSyntaxErrorsAreClear) {
  EXPECT_THROW(load_config_file("/nonexistent/mfot.yaml"), ConfigError);
}

}  // namespace
}  // namespace mfot::service

namespace mfot::service {
namespace {

TEST(PipelineConfig, QueuesThreadsAndModelWaitAreReadAndRangeChecked) {
  const YAML::Node root = with_defaults(
      "preprocess:\n  threads: 3\n  queue_frames: 2\n"
      "tracker:\n  queue_scenes: 4\n  model_wait_ms: 250\n");
  const PreprocessConfig preprocess = load_preprocess_config(root);
  EXPECT_EQ(preprocess.preprocessor.threads, 3);
  EXPECT_EQ(preprocess.queue_frames, 2);
  const TrackerConfig tracker = load_tracker_config(root);
  EXPECT_EQ(tracker.scenes.max_scenes, 4u);
  EXPECT_EQ(tracker.scenes.model_wait.count(), 250);

  const PreprocessConfig automatic = load_preprocess_config(with_defaults("preprocess: {}\n"));
  EXPECT_GE(automatic.preprocessor.threads, 1) << "0 (the default) picks a count from the machine";
  EXPECT_LE(automatic.preprocessor.threads, 8);
  EXPECT_EQ(automatic.queue_frames, 1);  // the shipped default: the newest frame

  EXPECT_THROW(load_preprocess_config(with_defaults("preprocess:\n  threads: 65\n")), ConfigError);
  EXPECT_THROW(load_preprocess_config(with_defaults("preprocess:\n  queue_frames: 0\n")), ConfigError);
  EXPECT_THROW(load_tracker_config(with_defaults("tracker:\n  queue_scenes: 0\n")), ConfigError);
  EXPECT_THROW(load_tracker_config(with_defaults("tracker:\n  queue_scenes: 65\n")), ConfigError);
  EXPECT_THROW(load_tracker_config(with_defaults("tracker:\n  model_wait_ms: 0\n")), ConfigError);
}

// Every key of the built-in defaults is read by a loader: without it, loading fails naming it.
TEST(DefaultConfig, EveryKeyReachesALoader) {
  const auto load_all = [](const YAML::Node& root) {
    capture::load_capture_settings(config_section(root, "capture"));
    load_preprocess_config(root);
    load_tracker_config(root);
    load_merger_config(root);
  };
  const YAML::Node defaults = default_config();
  ASSERT_NO_THROW(load_all(defaults));
  int keys = 0;
  for (const char* section : {"capture", "preprocess", "tracker", "merger"}) {
    std::vector<std::vector<std::string>> paths;  // leaf keys, nested mappings (merger.world) included
    for (const auto& item : defaults[section]) {
      const std::string key = item.first.Scalar();
      if (item.second.IsMap()) {
        for (const auto& inner : item.second) paths.push_back({key, inner.first.Scalar()});
      } else {
        paths.push_back({key});
      }
    }
    for (const auto& path : paths) {
      YAML::Node without = YAML::Clone(defaults);
      if (path.size() == 1) {
        without[section].remove(path[0]);
      } else {
        without[section][path[0]].remove(path[1]);
      }
      const std::string name = std::string(section) + "." + path.front() + (path.size() == 2 ? "." + path[1] : "");
      try {
        load_all(without);
        ADD_FAILURE() << name << " is in configs/default.yaml but no loader reads it";
      } catch (const ConfigError& e) {
        EXPECT_NE(std::string(e.what()).find(name + ": missing"), std::string::npos) << e.what();
      }
      ++keys;
    }
  }
  EXPECT_GT(keys, 90);
}

// A config that leaves keys out runs the shipped configuration, not the option structs' thesis
// values: an empty file loads exactly as configs/default.yaml itself.
TEST(DefaultConfig, AnEmptyConfigIsTheShippedOne) {
  const std::string empty = ::testing::TempDir() + "mfot_empty_config.yaml";
  { std::ofstream(empty) << "# nothing\n"; }
  const YAML::Node from_empty = load_config_file(empty);
  const YAML::Node shipped = load_config_file(std::string(MFOT_SOURCE_DIR) + "/configs/default.yaml");
  EXPECT_EQ(YAML::Dump(from_empty), YAML::Dump(shipped));
  const TrackerConfig tracker = load_tracker_config(from_empty);
  const MergerConfig merger = load_merger_config(from_empty);
  const PreprocessConfig preprocess = load_preprocess_config(from_empty);
  // The values that differ from the thesis's option structs.
  EXPECT_TRUE(tracker.step.exclude_occluders);
  EXPECT_FLOAT_EQ(tracker.step.hold_occluded_share, 0.6f);
  EXPECT_EQ(tracker.filter.num_particles, 100);
  EXPECT_FLOAT_EQ(merger.manager.model_update.alpha, 0.0f);
  EXPECT_FLOAT_EQ(merger.manager.hidden_occluded_share, 0.6f);
  EXPECT_EQ(preprocess.queue_frames, 1);
  EXPECT_EQ(load_config_file("").size(), from_empty.size());  // no file at all: the same
  // A key of one's own changes that key only.
  const std::string one = ::testing::TempDir() + "mfot_one_key.yaml";
  { std::ofstream(one) << "tracker:\n  particles: 250\n"; }
  const YAML::Node changed = load_config_file(one);
  EXPECT_EQ(load_tracker_config(changed).filter.num_particles, 250);
  EXPECT_TRUE(load_tracker_config(changed).step.exclude_occluders);
}

// The configs shipped for real set-ups load through every loader.
TEST(DefaultConfig, TheRealTableTopConfigLoads) {
  const YAML::Node root = load_config_file(std::string(MFOT_SOURCE_DIR) + "/configs/tabletop-real.yaml");
  const capture::CaptureSettings capture = capture::load_capture_settings(config_section(root, "capture"));
  EXPECT_EQ(capture.pcd_background_label_max, 9u);
  const PreprocessConfig preprocess = load_preprocess_config(root);
  EXPECT_FLOAT_EQ(preprocess.preprocessor.crop_max.z(), 1.6f);
  EXPECT_FLOAT_EQ(preprocess.preprocessor.plane_margin, 0.01f);
  EXPECT_FLOAT_EQ(preprocess.preprocessor.plane_margin_sigmas, 3.f);
  EXPECT_TRUE(preprocess.preprocessor.table_prism);
  EXPECT_NO_THROW(load_tracker_config(root));
  EXPECT_NO_THROW(load_merger_config(root));
}

}  // namespace
}  // namespace mfot::service
