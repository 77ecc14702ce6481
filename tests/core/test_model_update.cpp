#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <set>
#include <stdexcept>
#include <tuple>
#include <vector>

#include "mfot/model_updater.hpp"

namespace mfot {
namespace {

float uniform01(std::mt19937_64& rng) { return static_cast<float>(rng() >> 40) * 0x1.0p-24f; }

// n points in the object frame, all of one colour; features from compute_smr.
ObjectModel make_model(std::size_t n, Rgb8 color, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  ObjectModel model;
  for (std::size_t i = 0; i < n; ++i) {
    model.cloud.push_back(Eigen::Vector3f(uniform01(rng), uniform01(rng), uniform01(rng)) * 0.1f, color);
  }
  model.features = compute_smr(model.cloud.colors);
  return model;
}

Pose test_pose() {
  Pose pose;
  pose.translation = Eigen::Vector3f(0.1f, -0.2f, 0.9f);
  pose.rotation = Eigen::Quaternionf(Eigen::AngleAxisf(0.8f, Eigen::Vector3f(1.f, -1.f, 2.f).normalized()));
  return pose;
}

// Segmented points: object-frame points with distinct colours, moved into the camera frame.
struct Segment {
  std::vector<Eigen::Vector3f> object_frame;
  ColoredCloud camera_frame;
};

Segment make_segment(std::size_t n, const Pose& pose, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  Segment s;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f p = Eigen::Vector3f(uniform01(rng), uniform01(rng), uniform01(rng)) * 0.1f;
    s.object_frame.push_back(p);
    s.camera_frame.push_back(pose.isometry() * p,
                             Rgb8{static_cast<std::uint8_t>(i % 256), static_cast<std::uint8_t>(i / 256), 200});
  }
  return s;
}

bool same_feature(const SmrFeature& a, const SmrFeature& b) {
  return a.hue_bin == b.hue_bin && a.gray_bin == b.gray_bin && a.hue_weight_lo == b.hue_weight_lo &&
         a.hue_weight_hi == b.hue_weight_hi && a.gray_weight == b.gray_weight;
}

// Index of the segmented point that a new model point came from (matched by colour), or -1.
int segment_index(const Rgb8& c) { return c.b == 200 ? c.r + 256 * c.g : -1; }

constexpr Rgb8 kOldColor{220, 30, 30};

// The thesis's uniform forgetting (seen_radius 0) unless a test asks for the occlusion-aware one.
ModelUpdateOptions options(float alpha, std::uint64_t seed, std::size_t target_size = 0, float seen_radius = 0.f) {
  ModelUpdateOptions o;
  o.alpha = alpha;
  o.seed = seed;
  o.target_size = target_size;
  o.seen_radius = seen_radius;
  return o;
}

TEST(ModelUpdate, RejectsInvalidOptionsAndInputs) {
  EXPECT_THROW(ModelUpdater(options(-0.1f, 1)), std::invalid_argument);
  EXPECT_THROW(ModelUpdater(options(1.5f, 1)), std::invalid_argument);
  EXPECT_THROW(ModelUpdater(options(0.1f, 1, 0, -0.01f)), std::invalid_argument);
  ModelUpdater updater;
  ObjectModel broken = make_model(10, kOldColor, 1);
  broken.features.pop_back();
  EXPECT_THROW(updater.update(broken, ColoredCloud{}, Pose{}), std::invalid_argument);
  const ObjectModel model = make_model(10, kOldColor, 1);
  const std::vector<std::int32_t> labels = {1};
  EXPECT_THROW(updater.update(model, ColoredCloud{}, labels, 1, Pose{}), std::invalid_argument);
}

TEST(ModelUpdate, KeepsWhatIsNotSeenAndForgetsOnlySeenPoints) {
  // The old model fills a 10 cm cube; this frame only its x < 4 cm half is segmented (a hand
  // covers the rest). Every old point of the covered half must survive the update.
  const ObjectModel old_model = make_model(1000, kOldColor, 1);
  const Pose pose = test_pose();
  Segment segment = make_segment(3000, pose, 2);
  ColoredCloud visible;
  for (std::size_t i = 0; i < segment.camera_frame.size(); ++i) {
    if (segment.object_frame[i].x() < 0.04f)
      visible.push_back(segment.camera_frame.positions[i], segment.camera_frame.colors[i]);
  }
  ModelUpdater updater(options(0.2f, 3, 0, 0.01f));
  const ObjectModel updated = updater.update(old_model, visible, pose);
  ASSERT_EQ(updated.cloud.size(), old_model.cloud.size());
  std::size_t old_kept = 0, covered_old = 0, covered_kept = 0;
  std::multiset<std::tuple<float, float, float>> kept;
  for (std::size_t i = 0; i < updated.cloud.size(); ++i) {
    if (segment_index(updated.cloud.colors[i]) >= 0) continue;
    const auto& p = updated.cloud.positions[i];
    kept.insert({p.x(), p.y(), p.z()});
    ++old_kept;
  }
  for (const auto& p : old_model.cloud.positions) {
    if (p.x() <= 0.05f) continue;  // beyond seen_radius of every segmented point
    ++covered_old;
    covered_kept += kept.count({p.x(), p.y(), p.z()});
  }
  EXPECT_EQ(covered_kept, covered_old);
  EXPECT_EQ(old_kept, old_model.cloud.size() - 200u);  // alpha 0.2 of 1000 replaced, all from the seen half
}

TEST(ModelUpdate, AlphaZeroKeepsTheModel) {
  const ObjectModel old_model = make_model(500, kOldColor, 1);
  const Segment segment = make_segment(300, test_pose(), 2);
  ModelUpdater updater(options(0.f, 3));
  const ObjectModel updated = updater.update(old_model, segment.camera_frame, test_pose());
  ASSERT_EQ(updated.cloud.size(), old_model.cloud.size());
  EXPECT_EQ(updated.cloud.positions, old_model.cloud.positions);
  EXPECT_EQ(updated.cloud.colors, old_model.cloud.colors);
  for (std::size_t i = 0; i < updated.features.size(); ++i)
    EXPECT_TRUE(same_feature(updated.features[i], old_model.features[i]));
}

TEST(ModelUpdate, AlphaOneReplacesTheModelBySegmentedPointsInTheObjectFrame) {
  const ObjectModel old_model = make_model(200, kOldColor, 1);
  const Pose pose = test_pose();
  const Segment segment = make_segment(500, pose, 2);
  ModelUpdater updater(options(1.f, 3));
  const ObjectModel updated = updater.update(old_model, segment.camera_frame, pose);
  ASSERT_EQ(updated.cloud.size(), 200u);
  ASSERT_EQ(updated.features.size(), 200u);
  std::set<int> used;
  for (std::size_t i = 0; i < updated.cloud.size(); ++i) {
    const int s = segment_index(updated.cloud.colors[i]);
    ASSERT_GE(s, 0) << "an old point survived";
    EXPECT_TRUE(used.insert(s).second) << "a segmented point was drawn twice";
    EXPECT_LT((updated.cloud.positions[i] - segment.object_frame[static_cast<std::size_t>(s)]).norm(), 1e-5f);
    EXPECT_TRUE(same_feature(updated.features[i], compute_smr(updated.cloud.colors[i])));
  }
}

TEST(ModelUpdate, KeepsTheSizeSteadyAndMixesTheAlphaShare) {
  const ObjectModel old_model = make_model(1000, kOldColor, 1);
  const Pose pose = test_pose();
  const auto count_new = [](const ObjectModel& m) {
    std::size_t n = 0;
    for (const auto& c : m.cloud.colors) n += segment_index(c) >= 0;
    return n;
  };
  ModelUpdater updater(options(0.02f, 5));
  // Plenty of segmented points: 2 % of 1000 are new.
  const ObjectModel a = updater.update(old_model, make_segment(600, pose, 2).camera_frame, pose);
  EXPECT_EQ(a.cloud.size(), 1000u);
  EXPECT_EQ(count_new(a), 20u);
  // Only 7 segmented points: all of them are taken and 993 old points kept.
  const ObjectModel b = updater.update(old_model, make_segment(7, pose, 3).camera_frame, pose);
  EXPECT_EQ(b.cloud.size(), 1000u);
  EXPECT_EQ(count_new(b), 7u);
  // No segmented points at all: the model stays as it is.
  const ObjectModel c = updater.update(old_model, ColoredCloud{}, pose);
  EXPECT_EQ(c.cloud.positions, old_model.cloud.positions);
  // Kept old points stay in their original order (a subsequence of the old model).
  std::size_t cursor = 0;
  for (std::size_t i = 0; i < a.cloud.size(); ++i) {
    if (segment_index(a.cloud.colors[i]) >= 0) continue;
    while (cursor < old_model.cloud.size() && old_model.cloud.positions[cursor] != a.cloud.positions[i]) ++cursor;
    ASSERT_LT(cursor, old_model.cloud.size()) << "old points reordered or invented";
    ++cursor;
  }
  // Repeated updates keep the size.
  ObjectModel model = old_model;
  for (int t = 0; t < 20; ++t) model = updater.update(model, make_segment(300, pose, 10 + t).camera_frame, pose);
  EXPECT_EQ(model.cloud.size(), 1000u);
  EXPECT_EQ(model.features.size(), 1000u);
}

TEST(ModelUpdate, TargetSizeGrowsASmallModel) {
  const ObjectModel old_model = make_model(100, kOldColor, 1);
  const Pose pose = test_pose();
  ModelUpdater updater(options(0.1f, 5, 200));
  const ObjectModel grown = updater.update(old_model, make_segment(500, pose, 2).camera_frame, pose);
  EXPECT_EQ(grown.cloud.size(), 200u);  // all 100 old points plus 100 segmented ones
  std::size_t old_kept = 0;
  for (const auto& c : grown.cloud.colors) old_kept += c == kOldColor;
  EXPECT_EQ(old_kept, 100u);
}

TEST(ModelUpdate, DeterministicPerSeed) {
  const ObjectModel old_model = make_model(800, kOldColor, 1);
  const Pose pose = test_pose();
  const Segment segment = make_segment(400, pose, 2);
  ModelUpdater a(options(0.1f, 42));
  ModelUpdater b(options(0.1f, 42));
  ModelUpdater c(options(0.1f, 43));
  for (int t = 0; t < 3; ++t) {
    const ObjectModel ma = a.update(old_model, segment.camera_frame, pose);
    const ObjectModel mb = b.update(old_model, segment.camera_frame, pose);
    const ObjectModel mc = c.update(old_model, segment.camera_frame, pose);
    EXPECT_EQ(ma.cloud.positions, mb.cloud.positions);
    EXPECT_EQ(ma.cloud.colors, mb.cloud.colors);
    EXPECT_NE(ma.cloud.positions, mc.cloud.positions);
  }
}

TEST(ModelUpdate, LabelledSceneOverloadTakesOnlyTheObjectsPoints) {
  const ObjectModel old_model = make_model(300, kOldColor, 1);
  const Pose pose = test_pose();
  const Segment segment = make_segment(400, pose, 2);
  std::vector<std::int32_t> labels(segment.camera_frame.size());
  for (std::size_t i = 0; i < labels.size(); ++i) labels[i] = i % 2 == 0 ? 4 : 9;
  ModelUpdater updater(options(0.5f, 8));
  const ObjectModel updated = updater.update(old_model, segment.camera_frame, labels, 4, pose);
  EXPECT_EQ(updated.cloud.size(), 300u);
  std::size_t new_points = 0;
  for (const auto& c : updated.cloud.colors) {
    const int s = segment_index(c);
    if (s < 0) continue;
    ++new_points;
    EXPECT_EQ(labels[static_cast<std::size_t>(s)], 4);
  }
  EXPECT_EQ(new_points, 150u);
}

}  // namespace
}  // namespace mfot
