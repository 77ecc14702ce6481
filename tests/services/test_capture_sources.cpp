#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include "mfot/capture/capture_settings.hpp"
#include "mfot/capture/pacing.hpp"
#include "mfot/capture/sim_source.hpp"
#include "mfot/capture/tum_source.hpp"

namespace mfot::capture {
namespace {
namespace fs = std::filesystem;
using namespace std::chrono_literals;

sim::SimulatorOptions small_scenario(const std::string& name, int frames) {
  sim::SimulatorOptions options;
  options.scenario.name = name;
  options.scenario.num_frames = frames;
  options.camera.width = 96;
  options.camera.height = 72;
  options.camera.fx = options.camera.fy = 86.0f;
  options.camera.cx = 47.5f;
  options.camera.cy = 35.5f;
  return options;
}

class TempFolder {
 public:
  TempFolder() {
    const auto* info = testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() /
            ("mfot_" + std::string(info->test_suite_name()) + "_" + info->name() + "_" + std::to_string(::getpid()));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  TempFolder(const TempFolder&) = delete;
  TempFolder& operator=(const TempFolder&) = delete;
  ~TempFolder() {
    std::error_code error;
    fs::remove_all(path_, error);
  }
  std::string str(const std::string& child) const { return (path_ / child).string(); }

 private:
  fs::path path_;
};

void expect_same_truth(const service::GroundTruthFrame& a, const service::GroundTruthFrame& b) {
  ASSERT_EQ(a.objects.size(), b.objects.size());
  for (std::size_t i = 0; i < a.objects.size(); ++i) {
    EXPECT_EQ(a.objects[i].id, b.objects[i].id);
    EXPECT_EQ(a.objects[i].is_hand, b.objects[i].is_hand);
    EXPECT_TRUE(a.objects[i].pose.translation.isApprox(b.objects[i].pose.translation, 1e-6f));
    EXPECT_NEAR(a.objects[i].pose.rotation.angularDistance(b.objects[i].pose.rotation), 0.0f, 1e-4f);
  }
  EXPECT_EQ(a.labels.pixels, b.labels.pixels);
}

TEST(SimSource, DeliversTheSimulatorFramesWithGroundTruth) {
  const auto options = small_scenario("stack", 3);
  SimSource source(options);
  EXPECT_EQ(source.name(), "sim:stack");
  EXPECT_EQ(source.kind(), "sim");
  EXPECT_FALSE(source.live());
  const sim::Simulator reference(options);
  std::int64_t last_utime = -1;
  for (int i = 0; i < 3; ++i) {
    const auto item = source.next();
    ASSERT_TRUE(item.has_value());
    const sim::RenderedFrame expected = reference.render(i);
    EXPECT_EQ(item->index, i);
    EXPECT_EQ(item->frame.width, 96);
    EXPECT_EQ(item->frame.height, 72);
    EXPECT_EQ(item->frame.fx, 86.0f);
    EXPECT_EQ(item->frame.cy, 35.5f);
    EXPECT_NO_THROW(item->frame.validate());
    EXPECT_EQ(item->frame.depth_mm, expected.depth_mm);
    EXPECT_EQ(item->frame.color, expected.color);
    EXPECT_GT(item->frame.capture_utime, last_utime);
    last_utime = item->frame.capture_utime;
    ASSERT_TRUE(item->truth.has_value());
    EXPECT_EQ(item->truth->frame, i);
    EXPECT_EQ(item->truth->utime, item->frame.capture_utime);
    // Ground truth labels the measured pixels only.
    std::vector<std::uint16_t> measured_labels = expected.labels;
    for (std::size_t p = 0; p < measured_labels.size(); ++p) {
      if (expected.depth_mm[p] == 0) measured_labels[p] = 0;
    }
    EXPECT_EQ(item->truth->labels.pixels, measured_labels);
    ASSERT_EQ(item->truth->objects.size(), expected.poses.size());
    EXPECT_FALSE(expected.poses.empty());
    for (std::size_t k = 0; k < expected.poses.size(); ++k) {
      EXPECT_EQ(item->truth->objects[k].id, expected.poses[k].id);
      EXPECT_EQ(item->truth->objects[k].is_hand, expected.poses[k].is_hand);
    }
  }
  EXPECT_FALSE(source.next().has_value());
}

TEST(SimSource, SeeksAndRewinds) {
  SimSource source(small_scenario("static", 4));
  source.seek(2);
  const auto third = source.next();
  ASSERT_TRUE(third.has_value());
  EXPECT_EQ(third->index, 2);
  EXPECT_TRUE(source.rewind());
  const auto first = source.next();
  ASSERT_TRUE(first.has_value());
  EXPECT_EQ(first->index, 0);
  EXPECT_THROW(source.seek(4), CaptureError);
  EXPECT_THROW(source.seek(-1), CaptureError);
}

TEST(TumSource, ReplaysARenderedFolderWithItsGroundTruth) {
  TempFolder temp;
  SimSource sim(small_scenario("contact", 3));
  std::vector<SourceFrame> written;
  {
    service::TumWriterOptions options;
    options.folder = temp.str("seq");
    service::TumDatasetWriter writer(options);
    while (auto item = sim.next()) {
      writer.write(item->frame, &*item->truth);
      written.push_back(std::move(*item));
    }
  }
  service::TumReaderOptions options;
  options.folder = temp.str("seq");
  TumSource source(options);
  EXPECT_EQ(source.kind(), "tum");
  EXPECT_EQ(source.name(), "tum:" + temp.str("seq"));
  ASSERT_EQ(source.size(), written.size());
  for (const auto& expected : written) {
    const auto item = source.next();
    ASSERT_TRUE(item.has_value());
    EXPECT_EQ(item->frame.capture_utime, expected.frame.capture_utime);
    EXPECT_EQ(item->frame.fx, expected.frame.fx);
    EXPECT_EQ(item->frame.depth_mm, expected.frame.depth_mm);
    EXPECT_EQ(item->frame.color, expected.frame.color);
    ASSERT_TRUE(item->truth.has_value());
    EXPECT_EQ(item->truth->frame, expected.index);
    expect_same_truth(*item->truth, *expected.truth);
  }
  EXPECT_FALSE(source.next().has_value());

  // A frame whose image disappeared is skipped; the next one follows.
  fs::remove(source.reader().entry(1).rgb_path);
  ASSERT_TRUE(source.rewind());
  EXPECT_EQ(source.next()->index, 0);
  EXPECT_EQ(source.next()->index, 2);
  EXPECT_THROW(source.seek(3), CaptureError);
}

// A finite source without its own seek, for the default implementation.
class CountingSource final : public FrameSource {
 public:
  explicit CountingSource(int count) : count_(count) {}
  std::optional<SourceFrame> next() override {
    if (index_ >= count_) return std::nullopt;
    SourceFrame item;
    item.index = index_++;
    return item;
  }
  std::string name() const override { return "counting"; }
  std::string kind() const override { return "test"; }

 private:
  int count_;
  int index_ = 0;
};

TEST(FrameSource, DefaultSeekDropsFramesAndRejectsTheEnd) {
  CountingSource source(5);
  source.seek(3);
  EXPECT_EQ(source.next()->index, 3);
  EXPECT_FALSE(source.rewind());
  CountingSource short_source(2);
  EXPECT_THROW(short_source.seek(3), CaptureError);
}

TEST(RealtimeSchedule, FollowsSourceTimeScaledBySpeed) {
  const auto t0 = RealtimeSchedule::Clock::time_point{} + 100s;
  RealtimeSchedule normal(1.0);
  EXPECT_EQ(normal.due(5'000'000, t0), t0);
  EXPECT_EQ(normal.due(5'033'000, t0 + 1ms), t0 + 33ms);
  EXPECT_EQ(normal.due(5'100'000, t0 + 40ms), t0 + 100ms);

  RealtimeSchedule double_speed(2.0);
  EXPECT_EQ(double_speed.due(0, t0), t0);
  EXPECT_EQ(double_speed.due(100'000, t0), t0 + 50ms);
}

TEST(RealtimeSchedule, ReanchorsWhenTimeGoesBackOrThePublisherLags) {
  const auto t0 = RealtimeSchedule::Clock::time_point{} + 100s;
  RealtimeSchedule schedule(1.0, 500ms);
  schedule.due(1'000'000, t0);
  // Time went backwards (a loop): due at once, and later frames count from there.
  EXPECT_EQ(schedule.due(0, t0 + 10ms), t0 + 10ms);
  EXPECT_EQ(schedule.due(33'000, t0 + 10ms), t0 + 43ms);
  // 2 s late: no burst of overdue frames, the schedule restarts at now.
  const auto late = t0 + 2043ms;
  EXPECT_EQ(schedule.due(66'000, late), late);
  EXPECT_EQ(schedule.due(99'000, late), late + 33ms);
  EXPECT_THROW(RealtimeSchedule(0.0), std::invalid_argument);
  EXPECT_THROW(RealtimeSchedule(1.0, 0ms), std::invalid_argument);
}

TEST(LockstepGate, ReleasesWhenThePublishedFrameIsAnswered) {
  const auto t0 = LockstepGate::Clock::time_point{};
  LockstepGate gate;  // a window of one frame
  EXPECT_TRUE(gate.can_publish());
  gate.published(5, t0);
  EXPECT_FALSE(gate.can_publish());
  gate.answered(4);
  EXPECT_FALSE(gate.can_publish());
  gate.answered(5);
  EXPECT_TRUE(gate.can_publish());
  EXPECT_TRUE(gate.drained());
  gate.published(6, t0);
  gate.answered(8);  // newer answers imply the older frame is done
  EXPECT_TRUE(gate.can_publish());
  gate.published(9, t0);
  gate.abandon_oldest();
  EXPECT_TRUE(gate.can_publish());
}

TEST(LockstepGate, KeepsAtMostTheWindowInFlightAndTimesTheOldest) {
  using namespace std::chrono_literals;
  const auto t0 = LockstepGate::Clock::time_point{} + 1s;
  LockstepGate gate(3);
  gate.published(0, t0);
  gate.published(1, t0 + 10ms);
  EXPECT_TRUE(gate.can_publish());
  gate.published(2, t0 + 20ms);
  EXPECT_FALSE(gate.can_publish());
  EXPECT_EQ(gate.oldest(), 0);
  EXPECT_EQ(gate.oldest_published_at(), t0);
  gate.answered(0);
  EXPECT_TRUE(gate.can_publish());
  EXPECT_EQ(gate.oldest(), 1);
  EXPECT_EQ(gate.oldest_published_at(), t0 + 10ms);
  gate.published(3, t0 + 30ms);
  gate.abandon_oldest();  // frame 1 timed out
  EXPECT_EQ(gate.oldest(), 2);
  gate.answered(3);  // answers 2 as well
  EXPECT_TRUE(gate.drained());
  EXPECT_FALSE(gate.oldest().has_value());
  EXPECT_THROW(LockstepGate(0), std::invalid_argument);
  EXPECT_THROW(LockstepGate(9), std::invalid_argument);
}

TEST(CaptureSettings, ReadsTheConfigSectionStrictly) {
  const YAML::Node root = service::merged_over_defaults(
      YAML::Load("capture:\n  source: tum\n  folder: /data/fr1\n  rate: lockstep\n  lockstep_timeout_s: 1.5\n"
                 "  depth_encoding: raw\n  color_encoding: png\n  scenario: rotate\n  seed: 7\n  max_frames: 10\n"));
  const CaptureSettings settings = load_capture_settings(service::config_section(root, "capture"));
  EXPECT_EQ(settings.source, "tum");
  EXPECT_EQ(settings.tum_folder, "/data/fr1");
  EXPECT_EQ(settings.rate, RateMode::kLockstep);
  EXPECT_EQ(settings.lockstep_timeout_s, 1.5);
  EXPECT_EQ(settings.encoding.depth, service::DepthEncoding::kRaw);
  EXPECT_EQ(settings.encoding.color, service::ColorEncoding::kPng);
  EXPECT_EQ(settings.scenario, "rotate");
  EXPECT_EQ(settings.seed, 7u);
  EXPECT_EQ(settings.max_frames, 10);
  EXPECT_NO_THROW(settings.validate());

  const auto load = [](const std::string& text) {
    return load_capture_settings(service::config_section(service::merged_over_defaults(YAML::Load(text)), "capture"));
  };
  EXPECT_THROW(load("capture:\n  sorce: sim\n"), service::ConfigError);
  EXPECT_THROW(load("capture:\n  scenario: juggling\n"), service::ConfigError);
  EXPECT_THROW(load("capture:\n  jpeg_quality: 101\n"), service::ConfigError);
  EXPECT_THROW(load("capture:\n  rate: slow\n"), service::ConfigError);
  EXPECT_EQ(load("capture:\n  lockstep_window: 4\n").lockstep_window, 4);
  EXPECT_THROW(load("capture:\n  lockstep_window: 0\n"), service::ConfigError);
  EXPECT_THROW(load("capture:\n  lockstep_window: 9\n"), service::ConfigError);
  EXPECT_THROW(load("capture:\n  source: tum\n").validate(), service::ConfigError);
  EXPECT_THROW(load("capture:\n  source: oni\n").validate(), service::ConfigError);
}

TEST(CaptureSettings, MakeSourceReportsUnusableSources) {
  TempFolder temp;
  CaptureSettings settings;
  settings.source = "tum";
  settings.tum_folder = temp.str("absent");
  try {
    make_source(settings, {});
    ADD_FAILURE() << "missing TUM folder accepted";
  } catch (const CaptureError& e) {
    EXPECT_NE(std::string(e.what()).find("no such folder"), std::string::npos) << e.what();
  }
  settings.source = "oni";
  settings.oni_file = temp.str("absent.oni");
  try {
    make_source(settings, {});
    ADD_FAILURE() << "missing .oni recording accepted";
  } catch (const CaptureError& e) {
    EXPECT_NE(std::string(e.what()).find(openni2_available() ? "absent.oni: no such .oni recording" : "needs OpenNI2"),
              std::string::npos)
        << e.what();
  }
  settings.source = "sim";
  settings.scenario = "random";
  const auto sim = make_source(settings, {});
  EXPECT_EQ(sim->name(), "sim:random");
}

}  // namespace
}  // namespace mfot::capture
