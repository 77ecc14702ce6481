// Smoothed Color Ranging (thesis 3.2.1, equations 3.5-3.10). Expected vectors are worked out by
// hand from the formulas in ALGORITHM.md; the arithmetic is in the comments.
#include <gtest/gtest.h>

#include <array>
#include <random>
#include <stdexcept>

#include "mfot/smr_feature.hpp"

namespace mfot {
namespace {

using Dense = std::array<float, kSmrBins>;

void expect_dense(Rgb8 color, const Dense& expected) {
  const Dense h = compute_smr(color).dense();
  for (int c = 0; c < kSmrBins; ++c) {
    EXPECT_NEAR(h[c], expected[c], 1e-5f)
        << "bin " << c << " of (" << int(color.r) << "," << int(color.g) << "," << int(color.b) << ")";
  }
}

TEST(Smr, PureRedIsEntirelyTheRedBin) {
  // V = 1, S = 1 - 0/1 = 1, H = 0. w_C = 1^(0.14 * 1^-0.9) = 1, w_G = 0.
  // n = floor(0/60) + 1 = 1, n' = 2: bin 1 gets (60 - 0)/60 = 1, bin 2 gets 0.
  expect_dense({255, 0, 0}, {1, 0, 0, 0, 0, 0, 0, 0});
}

TEST(Smr, ThirtyDegreesSplitsEvenlyBetweenRedAndYellow) {
  // (254, 127, 0): V = 254/255, S = 1, H = 60 * (127 - 0)/(254 - 0) = 30.
  // w_C = 1^(...) = 1. bin 1 gets (60 - 30)/60 = 0.5, bin 2 gets 0.5; w_G = 0.
  expect_dense({254, 127, 0}, {0.5f, 0.5f, 0, 0, 0, 0, 0, 0});
}

TEST(Smr, BlueishHueSplitsBetweenCyanAndBlue) {
  // (0, 64, 255): max = B, H = 60 * (4 + (0 - 64)/255) = 240 - 15.058824 = 224.941176.
  // n = floor(224.94/60) + 1 = 4 (cyan, 180), n' = 5 (blue, 240).
  // bin 4 gets (240 - 224.941176)/60 = 0.250980, bin 5 gets 0.749020. S = 1 so w_C = 1.
  expect_dense({0, 64, 255}, {0, 0, 0, 0.250980f, 0.749020f, 0, 0, 0});
}

TEST(Smr, PurpleRedWrapsToTheRedBin) {
  // (255, 0, 128): H = 60 * (0 - 128)/255 + 360 = 329.882353, n = 6 (purple, 300), n' = 1 (red,
  // R = 360). bin 6 gets (360 - 329.882353)/60 = 0.501961, bin 1 gets 0.498039. S = 1, w_C = 1.
  expect_dense({255, 0, 128}, {0.498039f, 0, 0, 0, 0, 0.501961f, 0, 0});
}

TEST(Smr, GreysAreAchromaticSplitAtHalfValue) {
  // S = 0 -> w_C = 0^(positive) = 0, w_G = 1.
  // (128,128,128): V = 128/255 = 0.50196 >= 0.5 -> light bin 8.
  expect_dense({128, 128, 128}, {0, 0, 0, 0, 0, 0, 0, 1});
  // (100,100,100): V = 100/255 = 0.39216 < 0.5 -> dark bin 7.
  expect_dense({100, 100, 100}, {0, 0, 0, 0, 0, 0, 1, 0});
}

TEST(Smr, BlackAndWhite) {
  // Black: V = 0 -> w_C = 0 by definition, w_G = 1, V < 0.5 -> bin 7.
  expect_dense({0, 0, 0}, {0, 0, 0, 0, 0, 0, 1, 0});
  // White: S = 1 - 1/1 = 0 -> w_C = 0, V = 1 -> bin 8.
  expect_dense({255, 255, 255}, {0, 0, 0, 0, 0, 0, 0, 1});
}

TEST(Smr, DarkSaturatedColours) {
  // (64, 0, 0): S = 1 -> w_C = 1 whatever V: a dark but pure red stays chromatic.
  expect_dense({64, 0, 0}, {1, 0, 0, 0, 0, 0, 0, 0});
  // (64, 32, 32): V = 64/255 = 0.250980, S = 1 - 32/64 = 0.5, H = 60 * (32 - 32)/32 = 0.
  // V^-0.9 = exp(0.9 * 1.382380) = 3.469958; exponent = 0.14 * 3.469958 = 0.485794;
  // w_C = 0.5^0.485794 = exp(-0.485794 * 0.693147) = exp(-0.336727) = 0.714104;
  // w_G = 0.285896 into dark bin 7.
  expect_dense({64, 32, 32}, {0.714104f, 0, 0, 0, 0, 0, 0.285896f, 0});
}

TEST(Smr, LightDesaturatedOrange) {
  // (255, 191, 128): V = 1, S = 1 - 128/255 = 0.498039; w_C = S^(0.14 * 1) =
  // exp(0.14 * ln 0.498039) = exp(0.14 * -0.697076) = exp(-0.097591) = 0.907020, w_G = 0.092980.
  // H = 60 * (191 - 128)/(255 - 128) = 29.763780; bin 1 share (60 - 29.763780)/60 = 0.503937.
  // bin 1: 0.907020 * 0.503937 = 0.457081; bin 2: 0.907020 * 0.496063 = 0.449939; bin 8: 0.092980.
  expect_dense({255, 191, 128}, {0.457081f, 0.449939f, 0, 0, 0, 0, 0, 0.092980f});
}

TEST(Smr, RandomColoursHaveUnitL1NormAndAtMostThreeBins) {
  std::mt19937_64 rng(7);
  for (int k = 0; k < 5000; ++k) {
    const std::uint64_t bits = rng();
    const Rgb8 color{static_cast<std::uint8_t>(bits), static_cast<std::uint8_t>(bits >> 8),
                     static_cast<std::uint8_t>(bits >> 16)};
    const SmrFeature f = compute_smr(color);
    const Dense h = f.dense();
    float l1 = 0.f;
    int non_zero = 0;
    for (int c = 0; c < kSmrBins; ++c) {
      EXPECT_GE(h[c], 0.f);
      l1 += h[c];
      if (h[c] != 0.f) {
        ++non_zero;
        EXPECT_TRUE(c == f.hue_bin || c == (f.hue_bin + 1) % 6 || c == f.gray_bin) << "bin " << c;
      }
    }
    EXPECT_NEAR(l1, 1.f, 1e-5f);
    EXPECT_LE(non_zero, 3);
    EXPECT_LT(f.hue_bin, 6);
    EXPECT_TRUE(f.gray_bin == 6 || f.gray_bin == 7);
  }
}

TEST(Smr, BatchMatchesSingle) {
  const std::array<Rgb8, 3> colors{Rgb8{10, 200, 30}, Rgb8{0, 0, 0}, Rgb8{90, 90, 250}};
  const std::vector<SmrFeature> batch = compute_smr(colors);
  ASSERT_EQ(batch.size(), colors.size());
  for (std::size_t k = 0; k < colors.size(); ++k) EXPECT_EQ(batch[k].dense(), compute_smr(colors[k]).dense());
}

TEST(Smr, InvalidOptionsThrow) {
  EXPECT_THROW(compute_smr(Rgb8{1, 2, 3}, SmrOptions{0.f, 0.9f}), std::invalid_argument);
  EXPECT_THROW(compute_smr(Rgb8{1, 2, 3}, SmrOptions{1.5f, 0.9f}), std::invalid_argument);
  EXPECT_THROW(compute_smr(Rgb8{1, 2, 3}, SmrOptions{0.14f, -0.1f}), std::invalid_argument);
}

}  // namespace
}  // namespace mfot
