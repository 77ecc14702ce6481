#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

#include "mfot/model_parts.hpp"
#include "synthetic_object.hpp"

namespace mfot {
namespace {

// A 10 cm cube's surface at 5 mm spacing (600 points) as one part.
ObjectModel cube_model(float phase = 0.f) {
  return test::make_model(
      test::make_colored_box(Eigen::Vector3f::Constant(0.1f), 0.005f, test::kSixColours, nullptr, phase));
}

TEST(ModelParts, EvenSubsetKeepsEverythingUnderTheLimitAndSpreadsOverTheExtent) {
  const ObjectModel model = cube_model();
  const std::size_t n = model.cloud.size();
  EXPECT_EQ(even_subset(model.cloud, n).size(), n);
  const std::vector<std::uint32_t> half = even_subset(model.cloud, n / 2);
  ASSERT_LE(half.size(), n / 2);
  EXPECT_GE(half.size(), n / 4);  // the leaf grows by 25 % steps: not far below the limit
  EXPECT_TRUE(std::is_sorted(half.begin(), half.end()));
  Eigen::AlignedBox3f kept;
  for (const std::uint32_t k : half) kept.extend(model.cloud.positions[k]);
  EXPECT_GT(kept.sizes().minCoeff(), 0.08f);  // every face still covered, not the first half of the points
}

TEST(ModelParts, ThinningKeepsPartEndsAndFeaturesWithTheirPoints) {
  ObjectModel model = cube_model();
  const std::size_t first = model.cloud.size();
  std::vector<std::uint32_t> part_ends{static_cast<std::uint32_t>(first)};
  const ObjectModel second = cube_model(0.5f);  // the same cube sampled in between: a second view, a second part
  const std::vector<Eigen::Vector3f> moved(second.cloud.positions.begin(), second.cloud.positions.end());
  const ObjectModel both =
      with_part(model, moved, second.cloud.colors, second.features, 2 * first + 10, part_ends);  // under the limit
  ASSERT_EQ(part_ends,
            (std::vector<std::uint32_t>{static_cast<std::uint32_t>(first), static_cast<std::uint32_t>(2 * first)}));
  EXPECT_EQ(both.cloud.size(), 2 * first);
  std::vector<std::uint32_t> thinned_ends = part_ends;
  const ObjectModel small = thinned(both, first, thinned_ends);
  ASSERT_LE(small.cloud.size(), first);
  ASSERT_EQ(small.features.size(), small.cloud.size());
  ASSERT_FALSE(thinned_ends.empty());
  EXPECT_EQ(thinned_ends.back(), small.cloud.size());
  EXPECT_TRUE(std::is_sorted(thinned_ends.begin(), thinned_ends.end()));
  // Earlier points win their voxels: the first part keeps at least as many points as the second.
  EXPECT_GE(2 * thinned_ends.front(), small.cloud.size());
  for (std::size_t k = 0; k < small.cloud.size(); ++k) {
    const SmrFeature expected = compute_smr(small.cloud.colors[k]);
    EXPECT_EQ(small.features[k].hue_bin, expected.hue_bin) << "point " << k;
    EXPECT_EQ(small.features[k].hue_weight_lo, expected.hue_weight_lo) << "point " << k;
    EXPECT_EQ(small.features[k].gray_weight, expected.gray_weight) << "point " << k;
  }
}

TEST(ModelParts, AppendingRejectsMismatchedSizes) {
  std::vector<std::uint32_t> part_ends{1};
  ObjectModel model;
  model.cloud.push_back(Eigen::Vector3f::Zero(), test::kRed);
  model.features = compute_smr(model.cloud.colors);
  const std::vector<Eigen::Vector3f> points(2, Eigen::Vector3f::Zero());
  const std::vector<Rgb8> colors(1, test::kRed);
  EXPECT_THROW(with_part(model, points, colors, compute_smr(colors), 10, part_ends), std::invalid_argument);
}

}  // namespace
}  // namespace mfot
