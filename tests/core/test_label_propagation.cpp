#include <gtest/gtest.h>

#include <map>
#include <stdexcept>
#include <vector>

#include "mfot/label_propagation.hpp"

namespace mfot {
namespace {

// Points on the x axis at the given positions (metres).
std::vector<Eigen::Vector3f> on_a_line(const std::vector<float>& xs) {
  std::vector<Eigen::Vector3f> points;
  for (const float x : xs) points.emplace_back(x, 0.f, 1.f);
  return points;
}

using Gained = std::map<std::int32_t, std::vector<int>>;

TEST(LabelPropagation, LabelsSpreadInStepsOfTheRadiusNeverAcrossAWiderGap) {
  // 1 cm apart, then a 3 cm gap before the last point.
  const auto points = on_a_line({0.f, 0.01f, 0.02f, 0.03f, 0.06f});
  std::vector<std::int32_t> labels{7, 0, 0, 0, 0};
  const std::vector<int> cluster{0, 1, 2, 3, 4};
  LabelPropagation propagation(0.015f, 0.f);
  Gained gained;
  propagation.propagate(points, cluster, labels, gained);
  EXPECT_EQ(labels, (std::vector<std::int32_t>{7, 7, 7, 7, 0}));
  EXPECT_EQ(gained, (Gained{{7, {1, 2, 3}}}));  // in wave order
}

TEST(LabelPropagation, EachPointTakesTheLabelOfTheNearestPointOfItsWave) {
  // Two labelled ends; the middle points are reached from both sides in the same waves.
  const auto points = on_a_line({0.f, 0.01f, 0.021f, 0.03f, 0.04f});
  std::vector<std::int32_t> labels{1, 0, 0, 0, 2};
  LabelPropagation propagation(0.015f, 0.f);
  Gained gained;
  propagation.propagate(points, std::vector<int>{0, 1, 2, 3, 4}, labels, gained);
  // Wave 1: point 1 from 1, point 3 from 2; wave 2: point 2 is nearer point 3 (9 mm) than point 1 (11 mm).
  EXPECT_EQ(labels, (std::vector<std::int32_t>{1, 1, 2, 2, 2}));
  EXPECT_EQ(gained, (Gained{{1, {1}}, {2, {3, 2}}}));
}

TEST(LabelPropagation, AThinlySeededClusterOrARadiusOfZeroChangesNothing) {
  const auto points = on_a_line({0.f, 0.01f, 0.02f, 0.03f, 0.04f});
  const std::vector<std::int32_t> before{3, 0, 0, 0, 0};  // 1 of 5 points labelled: a share of 0.2
  const std::vector<int> cluster{0, 1, 2, 3, 4};
  Gained gained{{9, {9}}};
  {
    std::vector<std::int32_t> labels = before;
    LabelPropagation propagation(0.015f, 0.25f);
    propagation.propagate(points, cluster, labels, gained);
    EXPECT_EQ(labels, before);
    EXPECT_TRUE(gained.empty());  // cleared
  }
  {
    std::vector<std::int32_t> labels = before;
    LabelPropagation propagation(0.015f, 0.15f);  // seeded enough
    propagation.propagate(points, cluster, labels, gained);
    EXPECT_EQ(labels, (std::vector<std::int32_t>{3, 3, 3, 3, 3}));
  }
  {
    std::vector<std::int32_t> labels = before;
    LabelPropagation off(0.f, 0.f);
    off.propagate(points, cluster, labels, gained);
    EXPECT_EQ(labels, before);
  }
}

TEST(LabelPropagation, OnlyTheClustersPointsAreLookedAt) {
  const auto points = on_a_line({0.f, 0.01f, 0.02f});
  std::vector<std::int32_t> labels{4, 0, 0};
  LabelPropagation propagation(0.015f, 0.f);
  Gained gained;
  propagation.propagate(points, std::vector<int>{0, 2}, labels, gained);  // point 1 is another cluster's
  EXPECT_EQ(labels, (std::vector<std::int32_t>{4, 0, 0}));
  EXPECT_TRUE(gained.empty());
}

TEST(LabelPropagation, RejectsOutOfRangeSettings) {
  EXPECT_THROW(LabelPropagation(-0.01f, 0.f), std::invalid_argument);
  EXPECT_THROW(LabelPropagation(0.2f, 0.f), std::invalid_argument);
  EXPECT_THROW(LabelPropagation(0.015f, 1.5f), std::invalid_argument);
}

}  // namespace
}  // namespace mfot
