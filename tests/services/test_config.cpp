#include <gtest/gtest.h>

#include <fstream>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "mfot/capture/capture_settings.hpp"
#include "mfot/service/config.hpp"
#include "mfot/service/pipeline_config.hpp"

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

TEST(Config, TheTrackingStepsConstantsAreTheMethods) {
  // Keys no more (docs/method.md, Constants; docs/experiment-log.md): the services run the method's values, not the
  // option structs' thesis values.
  const TrackerConfig c = load_tracker_config(with_defaults("tracker:\n  particles: 50\n"));
  EXPECT_FLOAT_EQ(c.step.hypothesis.margin, 0.05f);
  EXPECT_FLOAT_EQ(c.step.hold_occluded_share, 0.6f);  // and the occluders left out of every stepped frame
  EXPECT_FLOAT_EQ(c.step.hold_min_scored_share, 0.2f);
  EXPECT_FLOAT_EQ(c.step.exclude_claimed_radius, 0.01f);  // and an isolated object followed harder
  EXPECT_FLOAT_EQ(c.step.isolated_motion.predicted_fraction, 0.75f);
  EXPECT_EQ(c.step.isolated_motion.refine_rounds, 2);
  EXPECT_FLOAT_EQ(c.step.last_pose_check_occluded_share, 0.15f);  // and the companion's pose checked (step 5d)
  EXPECT_NEAR(c.step.companion_turn_min, 0.7f * std::numbers::pi_v<float> / 180.f, 1e-7f);
  EXPECT_FLOAT_EQ(c.step.companion_turn_min_cosine, 0.8f);
  EXPECT_FLOAT_EQ(c.step.companion_turn_max_kept, 0.3f);
  EXPECT_GT(c.step.confidence_seen_through_weight, 0.f);
  EXPECT_FLOAT_EQ(c.filter.companion_fraction, 0.5f);
  EXPECT_FLOAT_EQ(c.filter.follow_replaced_estimate, 1.f);
  EXPECT_EQ(c.step.icp.max_points, 2000);
  EXPECT_FLOAT_EQ(c.step.icp.min_paired_share, 0.8f);
  EXPECT_FLOAT_EQ(c.step.icp.anchor_weight, 4.f);
  EXPECT_NO_THROW(c.step.validate());
  // The merger shares the hold's share (a hidden object's frames do not count towards its retirement) and sends with
  // each model what lies within the tracker's margin plus the claim radius.
  const MergerConfig m = load_merger_config(with_defaults(""));
  EXPECT_FLOAT_EQ(m.manager.hidden_occluded_share, 0.6f);
  EXPECT_FLOAT_EQ(m.claimed_margin, 0.06f);
  for (const std::string key :
       {"hypothesis_margin: 0.04", "exclude_occluders: true", "hold_occluded_share: 0.7", "exclude_claimed_radius: 0",
        "follow_isolated: false", "last_pose_check_occluded_share: 0.3", "companion_pose_check: false",
        "companion_turn_min_deg: 0", "companion_fraction: 0.3", "particles_follow_refinement: 0", "icp_max_points: 300",
        "icp_color_weight: 1", "icp_anchor_weight: 4", "companion_turn_max_kept: 0.4"}) {
    expect_rejected(load_tracker_config, "tracker:\n  " + key + "\n", key.substr(0, key.find(':')));
  }
}

TEST(Config, TheIcpKeysReachTheStep) {
  const TrackerConfig icp =
      load_tracker_config(with_defaults("tracker:\n  icp_iterations: 7\n  icp_max_distance: 0.02\n"));
  EXPECT_EQ(icp.step.icp.iterations, 7);
  EXPECT_FLOAT_EQ(icp.step.icp.max_distance, 0.02f);
  const std::pair<std::string, std::string> bad[] = {
      {"tracker:\n  icp_iterations: 51\n", "icp_iterations"},
      {"tracker:\n  icp_max_distance: 0.5\n", "icp_max_distance"},
  };
  for (const auto& [yaml, key] : bad) expect_rejected(load_tracker_config, yaml, key);
}

TEST(Config, ReidentificationKeysReachTheirOptions) {
  const MergerConfig m = load_merger_config(
      with_defaults("tracker:\n  cell_size: 0.02\nmerger:\n  reidentify_frames: 30\n  reidentify_similarity: 0.8\n"));
  EXPECT_EQ(m.manager.reidentify_frames, 30);
  EXPECT_FLOAT_EQ(m.manager.reidentify_similarity, 0.8f);
  const MergerConfig shipped = load_merger_config(with_defaults(""));
  // The method's constants (docs/method.md), not the option structs' thesis values: a box the hand brings back is
  // not swallowed by a few of the hand's points in its cluster, and a grown object is matched on enough of it.
  EXPECT_FLOAT_EQ(shipped.manager.propagation_min_seed_share, 0.1f);
  EXPECT_FLOAT_EQ(load_merger_config(with_defaults("merger:\n  propagation_min_seed_share: 0.2\n"))
                      .manager.propagation_min_seed_share,
                  0.2f);
  EXPECT_FLOAT_EQ(shipped.manager.reidentify_grown_min_share, 0.5f);
  EXPECT_FLOAT_EQ(shipped.manager.held_birth_margin, 0.02f);
  EXPECT_FLOAT_EQ(shipped.manager.join_split.split_min_departure, 0.03f);
  // The registration scores like the trackers.
  EXPECT_FLOAT_EQ(m.manager.registration.cell_size, 0.02f);
  // Switches of what always runs, and constants, are no keys.
  for (const std::string key :
       {"reidentify_min_fit: 0.6", "propagation_min_seed_share: 1.5", "seen_radius: 0.01", "reidentify_register: false",
        "reidentify_grown: false", "join_frames: 0", "split_frames: 0"}) {
    expect_rejected(load_merger_config, "merger:\n  " + key + "\n", key.substr(0, key.find(':')));
  }
}

TEST(Config, CarryCompanionAndRefitAreTheMethods) {
  const MergerConfig m = load_merger_config(with_defaults(""));
  // The method's constants (docs/method.md), not the option structs' thesis values (off).
  EXPECT_EQ(m.manager.carry.frames, 10);
  EXPECT_FLOAT_EQ(m.manager.carry.seen_through_share, 0.2f);
  EXPECT_FLOAT_EQ(m.manager.companion.contact_distance, 0.02f);
  EXPECT_EQ(m.manager.join_split.join_frames, 15);
  EXPECT_EQ(m.manager.join_split.split_frames, 5);
  const PartRefitOptions& r = m.manager.refit;
  EXPECT_NEAR(r.min_rotation, 0.5f * std::numbers::pi_v<float> / 180.f, 1e-7f);
  EXPECT_FLOAT_EQ(r.icp.min_paired_share, 0.8f);
  EXPECT_NEAR(r.icp.max_rotation, 10.f * std::numbers::pi_v<float> / 180.f, 1e-6f);
  EXPECT_EQ(r.icp.max_points, 1000);
  for (const std::string section : {"carry", "refit", "companion"}) {
    expect_rejected(load_merger_config, "merger:\n  " + section + ":\n    frames: 7\n", section);
  }
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

TEST(Config, DiscoveryKeysReachTheManager) {
  const MergerConfig m = load_merger_config(with_defaults("merger:\n  discovery:\n    min_part_points: 300\n"));
  EXPECT_EQ(m.manager.discovery.min_part_points, 300);
  EXPECT_EQ(m.manager.discovery.method, DiscoveryMethod::kLccp);  // the method's (the thesis: whole clusters)
  // The method's constants (docs/method.md): confirmed over 15 frames, boundaries drawn within 3 cm.
  EXPECT_EQ(m.manager.discovery.confirm_frames, 15);
  EXPECT_FLOAT_EQ(m.manager.discovery.boundary.radius, 0.03f);
  // The shipped supervoxel size: 2 cm finds the step between touching front faces that 3 cm straddles
  // (LccpDiscoveryOnSensorViews).
  EXPECT_FLOAT_EQ(m.manager.discovery.seed_resolution, 0.02f);
  // The shipped colour cut: off (convexity alone).
  EXPECT_FLOAT_EQ(m.manager.discovery.color_cut, 0.f);
  for (const std::string key : {"confirm_frames: 20", "confirm_votes: 4", "confirm_join: false", "color_cut: 201",
                                "method: clusters", "boundary_radius: 0.02", "min_part_points: 0"}) {
    expect_rejected(load_merger_config, "merger:\n  discovery:\n    " + key + "\n", key.substr(0, key.find(':')));
  }
  expect_rejected(load_merger_config, "merger:\n  new_object_held_margin: 0.05\n", "new_object_held_margin");
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
  EXPECT_FLOAT_EQ(load_tracker_config(changed).step.hold_occluded_share, 0.6f);
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
