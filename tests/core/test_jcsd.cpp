// JCSD grid (thesis 3.2.2-3.2.3, Algorithm 3, kernel 3.12) and its reference evaluation (3.18-3.19).
// Expected values are worked out by hand from K_r(d) = max(r - d, 0) / r; arithmetic in comments.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <random>
#include <stdexcept>

#include "mfot/jcsd_grid.hpp"
#include "mfot/likelihood.hpp"
#include "synthetic_object.hpp"

namespace mfot {
namespace {

constexpr float kCell = 0.015f;

float value_at(const JcsdGrid& g, int ix, int iy, int iz, int c) {
  return g.values[((static_cast<std::size_t>(iz) * g.dims[1] + iy) * g.dims[0] + ix) * kSmrBins + c];
}

float total(const JcsdGrid& g) { return std::accumulate(g.values.begin(), g.values.end(), 0.f); }

TEST(JcsdGrid, OnePointGivesTheKernelOnItsCellCorners) {
  // Anchor A = (0,0,0) pure red fixes the box minimum, so the origin is (-15,-15,-15) mm and corner
  // (1,1,1) sits at A. B = (4, 6, 9) mm pure blue lies in cell (1,1,1), whose corners are at
  // {0, 15} mm per axis. Each point has weight 1/n = 1/2.
  ColoredCloud cloud;
  cloud.push_back(Eigen::Vector3f(0.f, 0.f, 0.f), Rgb8{255, 0, 0});
  cloud.push_back(Eigen::Vector3f(0.004f, 0.006f, 0.009f), Rgb8{0, 0, 255});
  const JcsdGrid g = build_jcsd_grid(test::make_model(cloud), JcsdGridOptions{kCell, 1});

  // Extent (4, 6, 9) mm < 15 mm: 1 cell + 2 padding cells = 3 cells = 4 corners per axis.
  EXPECT_EQ(g.dims, (std::array<int, 3>{4, 4, 4}));
  EXPECT_TRUE(g.origin.isApprox(Eigen::Vector3f::Constant(-kCell)));

  constexpr int kRed = 0, kBlue = 4;  // (0,0,255): H = 240 -> bin 5 (1-based) takes (300-240)/60 = 1
  // A sits on corner (1,1,1): K(0) = 1; every other corner of its cell is >= 15 mm away: K = 0.
  EXPECT_NEAR(value_at(g, 1, 1, 1, kRed), 0.5f, 1e-6f);
  // B's offsets to the corners (mm) and K = (15 - d)/15, times 1/2:
  //  (0,0,0):   (4,6,9)   d = sqrt(133) = 11.532563 -> K = 0.231162 -> 0.115581
  //  (15,0,0):  (11,6,9)  d = sqrt(238) = 15.427249 -> 0
  //  (0,15,0):  (4,9,9)   d = sqrt(178) = 13.341664 -> K = 0.110556 -> 0.055278
  //  (15,15,0): (11,9,9)  d = sqrt(283) = 16.822604 -> 0
  //  (0,0,15):  (4,6,6)   d = sqrt(88)  =  9.380832 -> K = 0.374611 -> 0.187306
  //  (15,0,15): (11,6,6)  d = sqrt(193) = 13.892444 -> K = 0.073837 -> 0.036919
  //  (0,15,15): (4,9,6)   d = sqrt(133) = 11.532563 -> K = 0.231162 -> 0.115581
  //  (15,15,15):(11,9,6)  d = sqrt(238) = 15.427249 -> 0
  EXPECT_NEAR(value_at(g, 1, 1, 1, kBlue), 0.115581f, 1e-5f);
  EXPECT_NEAR(value_at(g, 2, 1, 1, kBlue), 0.f, 1e-7f);
  EXPECT_NEAR(value_at(g, 1, 2, 1, kBlue), 0.055278f, 1e-5f);
  EXPECT_NEAR(value_at(g, 2, 2, 1, kBlue), 0.f, 1e-7f);
  EXPECT_NEAR(value_at(g, 1, 1, 2, kBlue), 0.187306f, 1e-5f);
  EXPECT_NEAR(value_at(g, 2, 1, 2, kBlue), 0.036919f, 1e-5f);
  EXPECT_NEAR(value_at(g, 1, 2, 2, kBlue), 0.115581f, 1e-5f);
  EXPECT_NEAR(value_at(g, 2, 2, 2, kBlue), 0.f, 1e-7f);
  // Nothing anywhere else: 0.5 (A) + 0.115581 + 0.055278 + 0.187306 + 0.036919 + 0.115581.
  EXPECT_NEAR(total(g), 1.010665f, 1e-5f);
}

TEST(JcsdGrid, DensitySumsFollowTheKernel) {
  // With |h|_1 = 1 a point adds (1/n) sum over its 8 corners of K(d). Anchor at the origin
  // (corner (1,1,1), K = 1, sum 1) fixes the grid so cell boundaries are multiples of 15 mm:
  //  cell centre: 8 corners at d = sqrt(3)/2 r = 0.866025 r -> 8 * 0.133975 = 1.071797
  //  face centre: 4 corners at d = r / sqrt(2) -> 4 * (1 - 0.707107) = 1.171573; 4 at 1.22 r -> 0
  //  edge middle: 2 corners at d = r / 2 -> 2 * 0.5 = 1; the rest >= 1.118 r -> 0
  const float r = kCell;
  struct Case {
    Eigen::Vector3f offset;  // within a cell, in cells
    float kernel_sum;
  };
  const Case cases[] = {{{0.5f, 0.5f, 0.5f}, 1.071797f}, {{0.5f, 0.5f, 0.f}, 1.171573f}, {{0.5f, 0.f, 0.f}, 1.f}};
  for (const Case& c : cases) {
    ColoredCloud cloud;
    cloud.push_back(Eigen::Vector3f::Zero(), Rgb8{0, 255, 0});
    // Three copies in different cells: n = 4.
    for (int k = 0; k < 3; ++k) {
      cloud.push_back(r * (c.offset + Eigen::Vector3f(static_cast<float>(k + 1), 2.f, static_cast<float>(k))),
                      Rgb8{0, 255, 0});
    }
    const JcsdGrid g = build_jcsd_grid(test::make_model(cloud), JcsdGridOptions{r, 1});
    EXPECT_NEAR(total(g), (1.f + 3.f * c.kernel_sum) / 4.f, 1e-5f) << c.offset.transpose();
  }
}

TEST(JcsdGrid, ColourMassFollowsTheFeatures) {
  // Every point adds h(c) times the same kernel sum to channel c: channel totals are in the ratio
  // of the summed features. Half the points pure red, half pure green -> equal red/green mass.
  const ColoredCloud box =
      test::make_colored_box(Eigen::Vector3f(0.06f, 0.06f, 0.06f), 0.005f,
                             {test::kRed, test::kRed, test::kRed, test::kRed, test::kRed, test::kRed});
  ColoredCloud cloud;
  for (std::size_t k = 0; k < box.size(); ++k) {
    cloud.push_back(box.positions[k], k % 2 == 0 ? Rgb8{255, 0, 0} : Rgb8{0, 255, 0});
  }
  const JcsdGrid g = build_jcsd_grid(test::make_model(cloud));
  float red = 0.f, green = 0.f, other = 0.f;
  for (std::size_t s = 0; s < g.num_corners(); ++s) {
    for (int c = 0; c < kSmrBins; ++c) {
      const float v = g.values[s * kSmrBins + c];
      (c == 0 ? red : c == 2 ? green : other) += v;
    }
  }
  EXPECT_GT(red, 0.f);
  EXPECT_NEAR(red / green, 1.f, 0.05f);
  EXPECT_EQ(other, 0.f);
}

TEST(JcsdGrid, BuildingIsLinearInTheNumberOfPoints) {
  std::mt19937_64 rng(3);
  for (const std::size_t n : {10u, 100u, 1000u, 20000u}) {
    ColoredCloud cloud;
    for (std::size_t k = 0; k < n; ++k) {
      const std::uint64_t bits = rng();
      cloud.push_back(Eigen::Vector3f(static_cast<float>(bits & 0xffff), static_cast<float>((bits >> 16) & 0xffff),
                                      static_cast<float>((bits >> 32) & 0xffff)) *
                          (0.1f / 65535.f),
                      Rgb8{static_cast<std::uint8_t>(bits >> 48), static_cast<std::uint8_t>(bits >> 56), 7});
    }
    JcsdBuildStats stats;
    const JcsdGrid g = build_jcsd_grid(test::make_model(cloud), {}, &stats);
    EXPECT_EQ(stats.points, n);
    EXPECT_EQ(stats.kernel_evaluations, 8 * n);  // Algorithm 3: the 8 corners of each point's cell
    EXPECT_FALSE(g.empty());
  }
}

TEST(JcsdGrid, EmptyModelAndInvalidOptions) {
  JcsdBuildStats stats{5, 5};
  EXPECT_TRUE(build_jcsd_grid(ObjectModel{}, {}, &stats).empty());
  EXPECT_EQ(stats.kernel_evaluations, 0u);
  const ObjectModel model = test::make_model(test::make_test_object());
  EXPECT_THROW(build_jcsd_grid(model, JcsdGridOptions{0.f, 1}), std::invalid_argument);
  EXPECT_THROW(build_jcsd_grid(model, JcsdGridOptions{-0.01f, 1}), std::invalid_argument);
  EXPECT_THROW(build_jcsd_grid(model, JcsdGridOptions{0.015f, 0}), std::invalid_argument);
  ObjectModel broken = model;
  broken.features.pop_back();
  EXPECT_THROW(build_jcsd_grid(broken), std::invalid_argument);
}

TEST(JcsdPointScore, TrilinearInterpolationIsExactForLinearDensities) {
  // A grid whose red channel is the linear function 1 + 2x + 3y - z (grid units) interpolates it
  // exactly; the score of a pure red point (h = e_red) is that value, of a green point 0.
  JcsdGrid g;
  g.origin = Eigen::Vector3f(0.1f, -0.2f, 0.3f);
  g.cell_size = 0.01f;
  g.dims = {5, 4, 6};
  g.values.assign(g.num_corners() * kSmrBins, 0.f);
  for (int z = 0; z < g.dims[2]; ++z)
    for (int y = 0; y < g.dims[1]; ++y)
      for (int x = 0; x < g.dims[0]; ++x)
        g.values[((static_cast<std::size_t>(z) * g.dims[1] + y) * g.dims[0] + x) * kSmrBins] =
            1.f + 2.f * x + 3.f * y - 1.f * z + 6.f;
  const SmrFeature red = compute_smr(Rgb8{255, 0, 0});
  const SmrFeature green = compute_smr(Rgb8{0, 255, 0});
  const Eigen::Vector3f u(2.3f, 1.6f, 4.25f);  // grid units, inside
  const Eigen::Vector3f p = g.origin + g.cell_size * u;
  EXPECT_NEAR(jcsd_point_score(g, p, red), 1.f + 2.f * 2.3f + 3.f * 1.6f - 4.25f + 6.f, 1e-4f);
  EXPECT_EQ(jcsd_point_score(g, p, green), 0.f);
  // Outside the grid (or in the last layer of cells' far side) scores 0.
  EXPECT_EQ(jcsd_point_score(g, g.origin - Eigen::Vector3f::Constant(0.001f), red), 0.f);
  EXPECT_EQ(jcsd_point_score(g, g.origin + g.cell_size * Eigen::Vector3f(4.5f, 1.f, 1.f), red), 0.f);
}

}  // namespace
}  // namespace mfot
