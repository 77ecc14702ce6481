#include <gtest/gtest.h>

#include <vector>

#include "mfot/reidentification.hpp"
#include "mfot/smr_feature.hpp"

namespace mfot {
namespace {

// A model of n points of one colour.
ObjectModel painted(Rgb8 color, std::size_t n = 20) {
  ObjectModel model;
  for (std::size_t i = 0; i < n; ++i)
    model.cloud.push_back(Eigen::Vector3f(0.01f * static_cast<float>(i), 0, 0), color);
  model.features = compute_smr(model.cloud.colors, SmrOptions{});
  return model;
}

constexpr Rgb8 kRed{200, 30, 35};
constexpr Rgb8 kBlue{35, 70, 200};

RetiredObject retired_at(std::int64_t frame, const ObjectModel& last, const ObjectModel& first) {
  RetiredObject r;
  r.retired_frame = frame;
  r.histogram = color_histogram(last);
  r.first_seen = color_histogram(first);
  r.model = last;
  return r;
}

TEST(ColorHistogram, IsNormalisedAndEqualColoursAreSimilar) {
  const ColorHistogram red = color_histogram(painted(kRed));
  float total = 0.f;
  for (const float h : red) total += h;
  EXPECT_NEAR(total, 1.f, 1e-5f);
  EXPECT_NEAR(color_similarity(red, red), 1.f, 1e-5f);
  EXPECT_LT(color_similarity(red, color_histogram(painted(kBlue))), 0.5f);
  EXPECT_EQ(color_histogram(ObjectModel{}), ColorHistogram{});  // no points: all zero
}

TEST(RetiredObjects, MatchesTheLastOrFirstColoursOfObjectsRetiredByThen) {
  RetiredObjects memory(0.9f);
  memory.remember(3, retired_at(10, painted(kBlue), painted(kRed)));  // grown blue, first seen red
  const ColorHistogram red = color_histogram(painted(kRed));
  const ColorHistogram blue = color_histogram(painted(kBlue));
  EXPECT_EQ(memory.match(blue, 10), 3);
  EXPECT_EQ(memory.match(red, 10), 3);  // its first view
  EXPECT_EQ(memory.match(red, 9), 0);   // retired after frame 9: not by then
  const ColorHistogram green = color_histogram(painted({40, 200, 50}));
  EXPECT_EQ(memory.match(green, 10), 0);
}

TEST(RetiredObjects, TheBestMatchWinsAndTiesKeepTheLowestId) {
  RetiredObjects memory(0.5f);
  memory.remember(7, retired_at(1, painted(kRed), painted(kRed)));
  memory.remember(4, retired_at(1, painted(kRed), painted(kRed)));
  memory.remember(2, retired_at(1, painted({200, 120, 35}), painted({200, 120, 35})));  // orange: less similar
  EXPECT_EQ(memory.match(color_histogram(painted(kRed)), 1), 4);
  memory.forget(4);
  EXPECT_EQ(memory.match(color_histogram(painted(kRed)), 1), 7);
  EXPECT_EQ(memory.size(), 2u);
}

TEST(ModelRadius, IsTheLargestDistanceFromTheCentroid) {
  EXPECT_NEAR(model_radius(painted(kRed, 21)), 0.1f, 1e-5f);  // 0 .. 0.2 m on a line about 0.1
  EXPECT_EQ(model_radius(ObjectModel{}), 0.f);
}

TEST(RetiredObjects, AnUnseenObjectMatchesByColourAndANewcomerNoMoreThanTheRatioLarger) {
  const RetiredObjects memory(0.9f);
  const auto unseen = [](std::int32_t id, const ObjectModel& last, const ObjectModel& first, float radius) {
    return UnseenObject{id, color_histogram(last), color_histogram(first), radius};
  };
  const std::vector<UnseenObject> live{unseen(2, painted(kBlue), painted(kRed), 0.05f),  // grown blue, first seen red
                                       unseen(5, painted(kRed), painted(kRed), 0.05f),
                                       unseen(8, painted({40, 200, 50}), painted({40, 200, 50}), 0.2f)};
  const ColorHistogram red = color_histogram(painted(kRed));
  EXPECT_EQ(memory.match_unseen(live, red, 0.08f, 2.f), 2);  // ties (red first view, red): the lowest id
  EXPECT_EQ(memory.match_unseen(live, red, 0.12f, 2.f), 0);  // more than twice as large: neither
  EXPECT_EQ(memory.match_unseen(std::span(live).subspan(1), red, 0.1f, 2.f), 5);
  EXPECT_EQ(memory.match_unseen(live, color_histogram(painted(kBlue)), 0.01f, 2.f), 2);
  EXPECT_EQ(memory.match_unseen(live, color_histogram(painted({40, 200, 50})), 0.3f, 2.f), 8);
  EXPECT_EQ(memory.match_unseen(live, color_histogram(painted({200, 200, 200})), 0.01f, 2.f), 0);  // grey: none
  EXPECT_EQ(memory.match_unseen({}, red, 0.01f, 2.f), 0);
}

TEST(RetiredObjects, ForgetsThoseRetiredTheGivenFramesAgo) {
  RetiredObjects memory(0.9f);
  memory.remember(1, retired_at(0, painted(kRed), painted(kRed)));
  memory.remember(2, retired_at(5, painted(kBlue), painted(kBlue)));
  memory.expire(9, 10);
  EXPECT_EQ(memory.size(), 2u);
  memory.expire(10, 10);  // object 1 retired 10 frames before
  EXPECT_EQ(memory.size(), 1u);
  EXPECT_EQ(memory.at(2).retired_frame, 5);
  memory.expire(5, 0);  // remembered for no frame: everything goes
  EXPECT_EQ(memory.size(), 0u);
}

}  // namespace
}  // namespace mfot
