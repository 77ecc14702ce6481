#include "mfot/service/config.hpp"
#include "mfot/service/pipeline_config.hpp"

#include <gtest/gtest.h>

namespace mfot::service {
namespace {

ConfigSection section_of(const std::string& yaml, const std::string& name) {
  return config_section(YAML::Load(yaml), name);
}

TEST(Config, ReadsValuesAndDefaults) {
  auto s = section_of("tracker:\n  particles: 200\n  alpha: 0.05\n  backend: cpu\n", "tracker");
  EXPECT_EQ(s.get<int>("particles", 100, 1, 100000), 200);
  EXPECT_DOUBLE_EQ(s.get<double>("alpha", 0.02, 0.0, 1.0), 0.05);
  EXPECT_EQ(s.choice("backend", "auto", {"auto", "cuda", "cpu"}), "cpu");
  EXPECT_EQ(s.get<int>("threads", 3), 3);
  EXPECT_NO_THROW(s.finish());
}

TEST(Config, UnknownKeyIsRefusedWithItsName) {
  auto s = section_of("tracker:\n  particles: 200\n  partciles: 100\n", "tracker");
  s.get<int>("particles", 100);
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
    s.get<double>("alpha", 0.02, 0.0, 1.0);
    FAIL() << "alpha > 1 accepted";
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("merger.alpha"), std::string::npos) << what;
    EXPECT_NE(what.find("[0.0"), std::string::npos) << what;
  }
  auto zero = section_of("tracker:\n  particles: 0\n", "tracker");
  EXPECT_THROW(zero.get<int>("particles", 100, 1, 100000), ConfigError);
}

TEST(Config, WrongTypeIsRefused) {
  auto s = section_of("tracker:\n  particles: many\n", "tracker");
  try {
    s.get<int>("particles", 100);
    FAIL() << "string accepted as integer";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("expected an integer"), std::string::npos) << e.what();
  }
}

TEST(Config, BadChoiceListsAllowedValues) {
  auto s = section_of("tracker:\n  backend: opencl\n", "tracker");
  try {
    s.choice("backend", "auto", {"auto", "cuda", "cpu"});
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("auto|cuda|cpu"), std::string::npos) << e.what();
  }
}

TEST(Config, NestedSectionsAndVectors) {
  auto root = YAML::Load("merger:\n  world:\n    translation: [0, 0, 1]\n    bogus: 1\n");
  auto merger = config_section(root, "merger");
  auto world = merger.section("world");
  const auto t = world.get_vector("translation", {0, 0, 0}, 3);
  EXPECT_DOUBLE_EQ(t[2], 1.0);
  EXPECT_THROW(world.get_vector("translation", {}, 4), ConfigError);
  EXPECT_THROW(world.finish(), ConfigError);
  EXPECT_THROW(check_top_level(root, {"capture"}), ConfigError);
  EXPECT_NO_THROW(check_top_level(root, {"merger"}));
}

TEST(Config, TrackerOcclusionKeysReachTheTrackingStep) {
  const TrackerConfig c = load_tracker_config(YAML::Load(
      "tracker:\n  hypothesis_margin: 0.04\n  exclude_occluders: true\n  hold_occluded_share: 0.7\n"
      "  occluder_depth_margin: 0.02\n  own_surface_radius: 0.005\n  occlusion_window: 0.01\n"));
  EXPECT_FLOAT_EQ(c.step.hypothesis.margin, 0.04f);
  EXPECT_TRUE(c.step.exclude_occluders);
  EXPECT_FLOAT_EQ(c.step.hold_occluded_share, 0.7f);
  EXPECT_FLOAT_EQ(c.step.occlusion.depth_margin, 0.02f);
  EXPECT_FLOAT_EQ(c.step.occlusion.own_surface_radius, 0.005f);
  EXPECT_FLOAT_EQ(c.step.occlusion.window, 0.01f);
  // Absent keys: the thesis's step (every point scored, never held).
  const TrackerConfig thesis = load_tracker_config(YAML::Load("tracker:\n  particles: 50\n"));
  EXPECT_FALSE(thesis.step.exclude_occluders);
  EXPECT_EQ(thesis.step.hold_occluded_share, 0.f);
  try {
    load_tracker_config(YAML::Load("tracker:\n  occlusion_window: 0.5\n"));
    FAIL() << "occlusion_window 0.5 was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("occlusion_window"), std::string::npos) << e.what();
  }
  EXPECT_THROW(load_tracker_config(YAML::Load("tracker:\n  exclude_occluders: maybe\n")), ConfigError);
}

TEST(Config, MissingFileAndSyntaxErrorsAreClear) {
  EXPECT_THROW(load_config_file("/nonexistent/mfot.yaml"), ConfigError);
}

}  // namespace
}  // namespace mfot::service

namespace mfot::service {
namespace {

TEST(PipelineConfig, QueuesThreadsAndModelWaitAreReadAndRangeChecked) {
  const YAML::Node root = YAML::Load(
      "preprocess:\n  threads: 3\n  queue_frames: 2\n"
      "tracker:\n  queue_scenes: 4\n  model_wait_ms: 250\n");
  const PreprocessConfig preprocess = load_preprocess_config(root);
  EXPECT_EQ(preprocess.preprocessor.threads, 3);
  EXPECT_EQ(preprocess.queue_frames, 2);
  const TrackerConfig tracker = load_tracker_config(root);
  EXPECT_EQ(tracker.scenes.max_scenes, 4u);
  EXPECT_EQ(tracker.scenes.model_wait.count(), 250);

  const PreprocessConfig automatic = load_preprocess_config(YAML::Load("preprocess: {}\n"));
  EXPECT_GE(automatic.preprocessor.threads, 1) << "0 (the default) picks a count from the machine";
  EXPECT_LE(automatic.preprocessor.threads, 8);
  EXPECT_EQ(automatic.queue_frames, 8);

  EXPECT_THROW(load_preprocess_config(YAML::Load("preprocess:\n  threads: 65\n")), ConfigError);
  EXPECT_THROW(load_preprocess_config(YAML::Load("preprocess:\n  queue_frames: 0\n")), ConfigError);
  EXPECT_THROW(load_tracker_config(YAML::Load("tracker:\n  queue_scenes: 0\n")), ConfigError);
  EXPECT_THROW(load_tracker_config(YAML::Load("tracker:\n  queue_scenes: 65\n")), ConfigError);
  EXPECT_THROW(load_tracker_config(YAML::Load("tracker:\n  model_wait_ms: 0\n")), ConfigError);
}

}  // namespace
}  // namespace mfot::service
