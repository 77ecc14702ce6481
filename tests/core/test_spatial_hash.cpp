#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

#include "mfot/spatial_hash.hpp"

namespace mfot {
namespace {

std::vector<Eigen::Vector3f> random_points(std::size_t n, float extent, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<Eigen::Vector3f> points(n);
  for (auto& p : points) {
    for (int a = 0; a < 3; ++a) p[a] = extent * (static_cast<float>(rng() >> 11) * 0x1.0p-53f - 0.5f);
  }
  return points;
}

int brute_nearest(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3f& q, float max_distance,
                  float& d2_out) {
  int best = -1;
  float best_d2 = max_distance * max_distance;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const float d2 = (points[i] - q).squaredNorm();
    if (d2 < best_d2 || (d2 == best_d2 && best < 0)) {
      best_d2 = d2;
      best = static_cast<int>(i);
    }
  }
  d2_out = best_d2;
  return best;
}

TEST(SpatialHash, RejectsInvalidCellSize) {
  EXPECT_THROW(SpatialHash(0.f), std::invalid_argument);
  EXPECT_THROW(SpatialHash(-0.01f), std::invalid_argument);
  EXPECT_THROW(SpatialHash(std::numeric_limits<float>::quiet_NaN()), std::invalid_argument);
}

TEST(SpatialHash, EmptyIndexFindsNothing) {
  SpatialHash hash(0.01f);
  hash.build({});
  EXPECT_EQ(hash.size(), 0u);
  EXPECT_EQ(hash.nearest(Eigen::Vector3f::Zero(), 1.f), -1);
  std::vector<int> out;
  hash.radius_search(Eigen::Vector3f::Zero(), 1.f, out);
  EXPECT_TRUE(out.empty());
}

// 3000 random points in a 30 cm cube indexed in a hash of 1 cm cells, and queries over a 35 cm cube (some fall
// outside the points' box), each drawn from its own seed.
struct IndexedCloud {
  std::vector<Eigen::Vector3f> points;
  std::vector<Eigen::Vector3f> queries;
  SpatialHash hash{0.01f};
  IndexedCloud(std::size_t query_count, std::uint64_t point_seed, std::uint64_t query_seed)
      : points(random_points(3000, 0.3f, point_seed)), queries(random_points(query_count, 0.35f, query_seed)) {
    hash.build(points);
  }
};

class SpatialHashVsBruteForce : public ::testing::TestWithParam<float> {};

TEST_P(SpatialHashVsBruteForce, NearestMatchesBruteForce) {
  const float max_distance = GetParam();
  const auto& [points, queries, hash] = IndexedCloud(2000, 1, 2);
  ASSERT_EQ(hash.size(), points.size());
  int found = 0;
  for (const auto& q : queries) {
    float expected_d2 = 0.f;
    const int expected = brute_nearest(points, q, max_distance, expected_d2);
    float d2 = -1.f;
    const int got = hash.nearest(q, max_distance, &d2);
    ASSERT_EQ(got, expected);
    float near_first_d2 = -1.f;
    ASSERT_EQ(hash.nearest_near_first(q, max_distance, &near_first_d2), expected);
    if (expected >= 0) {
      EXPECT_EQ(d2, expected_d2);
      EXPECT_EQ(near_first_d2, expected_d2);
      ++found;
    }
  }
  EXPECT_GT(found, 0);  // the radii are large enough that some queries succeed
}

TEST_P(SpatialHashVsBruteForce, RadiusSearchMatchesBruteForce) {
  const float radius = GetParam();
  const auto& [points, queries, hash] = IndexedCloud(500, 3, 4);
  std::vector<int> got;
  for (const auto& q : queries) {
    std::vector<int> expected;
    for (std::size_t i = 0; i < points.size(); ++i) {
      if ((points[i] - q).squaredNorm() <= radius * radius) expected.push_back(static_cast<int>(i));
    }
    got.assign({-7});  // radius_search appends: existing content stays in front
    hash.radius_search(q, radius, got);
    ASSERT_EQ(got.front(), -7);
    got.erase(got.begin());
    ASSERT_EQ(got, expected);
  }
}

// The bound ICP relies on to skip queries (IcpRefinement): the same point as nearest, no other point nearer
// than the bound, and after any move the bound allows, still the nearest.
TEST_P(SpatialHashVsBruteForce, NearestWithBoundKeepsItsPointOverTheMovesItAllows) {
  const float max_distance = GetParam();
  const auto& [points, queries, hash] = IndexedCloud(2000, 5, 6);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<float> unit(-1.f, 1.f);
  int kept = 0;
  for (const auto& q : queries) {
    float d2 = -1.f;
    float others_d2 = -1.f;
    const int got = hash.nearest_with_bound(q, max_distance, d2, others_d2);
    float expected_d2 = 0.f;
    ASSERT_EQ(got, brute_nearest(points, q, max_distance, expected_d2));
    if (got >= 0) {
      EXPECT_EQ(d2, expected_d2);
    }
    EXPECT_LE(others_d2, max_distance * max_distance);
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (static_cast<int>(i) != got) {
        ASSERT_GE((points[i] - q).squaredNorm(), others_d2);
      }
    }
    if (got < 0) continue;
    // The largest move the bound allows, in a random direction: the nearest stays.
    const float slack = (std::sqrt(others_d2) - std::sqrt(d2)) / 2.f;
    if (slack <= 1e-5f) continue;
    const Eigen::Vector3f moved = q + (slack - 1e-5f) * Eigen::Vector3f(unit(rng), unit(rng), unit(rng)).normalized();
    float moved_d2 = 0.f;
    const int still = brute_nearest(points, moved, std::numeric_limits<float>::max(), moved_d2);
    ASSERT_EQ(still, got);
    ++kept;
  }
  EXPECT_GT(kept, 20);  // at the smallest radius few queries find a point at all
}

TEST_P(SpatialHashVsBruteForce, AnyWithinMatchesBruteForce) {
  const float radius = GetParam();
  const auto& [points, queries, hash] = IndexedCloud(1000, 8, 9);
  int found = 0;
  int found_odd = 0;
  for (const auto& q : queries) {
    bool any = false;
    bool any_odd = false;
    for (std::size_t i = 0; i < points.size(); ++i) {
      if ((points[i] - q).squaredNorm() > radius * radius) continue;
      any = true;
      any_odd = any_odd || i % 2 == 1;
    }
    ASSERT_EQ(hash.any_within(q, radius), any);
    ASSERT_EQ(hash.any_within(q, radius, [](int i) { return i % 2 == 1; }), any_odd);
    found += any ? 1 : 0;
    found_odd += any_odd ? 1 : 0;
  }
  EXPECT_GT(found, 0);
  EXPECT_GT(found_odd, 0);
}

// Radii below, at and above the cell size, and one wider than the whole cloud.
INSTANTIATE_TEST_SUITE_P(Radii, SpatialHashVsBruteForce, ::testing::Values(0.004f, 0.01f, 0.025f, 1.f));

TEST(SpatialHash, FarApartClustersMatchBruteForce) {
  // Two clouds 50 m apart: their bounding box spans too many cells for a dense grid, so this
  // exercises the sparse cell table.
  auto points = random_points(2000, 0.3f, 6);
  for (std::size_t i = 0; i < points.size(); i += 2) points[i] += Eigen::Vector3f(50.f, -20.f, 10.f);
  auto queries = random_points(600, 0.35f, 7);
  for (std::size_t i = 0; i < queries.size(); i += 3) queries[i] += Eigen::Vector3f(50.f, -20.f, 10.f);
  SpatialHash hash(0.01f);
  hash.build(points);
  for (const float radius : {0.006f, 0.02f, 0.05f, 100.f}) {
    for (const auto& q : queries) {
      float expected_d2 = 0.f;
      const int expected = brute_nearest(points, q, radius, expected_d2);
      ASSERT_EQ(hash.nearest(q, radius), expected);
      std::vector<int> expected_ball, got;
      for (std::size_t i = 0; i < points.size(); ++i) {
        if ((points[i] - q).squaredNorm() <= radius * radius) expected_ball.push_back(static_cast<int>(i));
      }
      hash.radius_search(q, radius, got);
      ASSERT_EQ(got, expected_ball);
    }
  }
}

TEST(SpatialHash, TiesGoToLowerIndex) {
  // Duplicated points and points equidistant from the query.
  const std::vector<Eigen::Vector3f> points = {
      {0.5f, 0.f, 0.f}, {0.f, 0.f, 0.0625f}, {0.f, 0.f, -0.0625f}, {0.f, 0.0625f, 0.f}, {0.f, 0.f, 0.0625f}};
  SpatialHash hash(0.01f);
  hash.build(points);
  float d2 = 0.f;
  EXPECT_EQ(hash.nearest(Eigen::Vector3f::Zero(), 0.1f, &d2), 1);
  EXPECT_FLOAT_EQ(d2, 0.0625f * 0.0625f);
  EXPECT_EQ(hash.nearest(Eigen::Vector3f(0.f, 0.f, 0.0625f), 0.01f), 1);

  // Reordering the input moves the winner with the lower index.
  const std::vector<Eigen::Vector3f> reordered = {points[3], points[2], points[1], points[0]};
  hash.build(reordered);
  EXPECT_EQ(hash.nearest(Eigen::Vector3f::Zero(), 0.1f), 0);
}

// Points on a lattice whose spacing divides the cell (so many lie on cell faces, and many are tied) and
// queries on the lattice, on cell faces and between: the queries pass over cells that cannot hold a
// nearer point, so a tie across a cell face is where they would go wrong.
TEST(SpatialHash, TiesAcrossCellFacesMatchBruteForce) {
  std::vector<Eigen::Vector3f> points;
  for (int z = -4; z <= 4; ++z) {
    for (int y = -4; y <= 4; ++y) {
      for (int x = -4; x <= 4; ++x) {
        if ((x * 7 + y * 3 + z) % 4 == 0) continue;  // holes, so the nearest is not always at distance 0
        points.emplace_back(0.0025f * x, 0.0025f * y, 0.0025f * z);
        if ((x + y + z) % 3 == 0) points.emplace_back(0.0025f * x, 0.0025f * y, 0.0025f * z);  // duplicates
      }
    }
  }
  SpatialHash hash(0.005f);
  hash.build(points);
  int compared = 0;
  for (int z = -10; z <= 10; ++z) {
    for (int y = -10; y <= 10; ++y) {
      for (int x = -10; x <= 10; ++x) {
        const Eigen::Vector3f q(0.00125f * x, 0.00125f * y, 0.00125f * z);
        for (const float max_distance : {0.0025f, 0.004f, 0.005f}) {
          float expected_d2 = 0.f;
          const int expected = brute_nearest(points, q, max_distance, expected_d2);
          float d2 = -1.f;
          const int got = hash.nearest(q, max_distance, &d2);
          ASSERT_EQ(got, expected) << q.transpose() << " within " << max_distance;
          const int got_near_first = hash.nearest_near_first(q, max_distance);
          ASSERT_EQ(got_near_first, expected) << q.transpose() << " within " << max_distance;
          if (expected >= 0) {
            EXPECT_EQ(d2, expected_d2);
          }
          // The bound: the least of max_distance^2 and every other point's squared distance.
          float expected_others = max_distance * max_distance;
          for (std::size_t i = 0; i < points.size(); ++i) {
            if (static_cast<int>(i) != expected)
              expected_others = std::min(expected_others, (points[i] - q).squaredNorm());
          }
          float bound_d2 = -1.f;
          float others_d2 = -1.f;
          ASSERT_EQ(hash.nearest_with_bound(q, max_distance, bound_d2, others_d2), expected);
          EXPECT_EQ(others_d2, expected_others);
          if (expected >= 0) {
            EXPECT_EQ(bound_d2, expected_d2);
          }
          ++compared;
        }
      }
    }
  }
  EXPECT_EQ(compared, 21 * 21 * 21 * 3);
}

TEST(SpatialHash, MaxDistanceIsInclusiveAndBounding) {
  const std::vector<Eigen::Vector3f> points = {{0.25f, 0.f, 0.f}};
  SpatialHash hash(0.01f);
  hash.build(points);
  EXPECT_EQ(hash.nearest(Eigen::Vector3f::Zero(), 0.25f), 0);
  EXPECT_EQ(hash.nearest(Eigen::Vector3f::Zero(), 0.2499f), -1);
  EXPECT_EQ(hash.nearest(Eigen::Vector3f::Zero(), -1.f), -1);
}

TEST(SpatialHash, NonFinitePointsAreSkipped) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<Eigen::Vector3f> points = {{nan, 0.f, 0.f}, {0.f, inf, 0.f}, {0.01f, 0.f, 0.f}};
  SpatialHash hash(0.01f);
  hash.build(points);
  EXPECT_EQ(hash.size(), 3u);
  EXPECT_EQ(hash.nearest(Eigen::Vector3f::Zero(), 1.f), 2);
  EXPECT_EQ(hash.nearest(Eigen::Vector3f(nan, 0.f, 0.f), 1.f), -1);
  std::vector<int> out;
  hash.radius_search(Eigen::Vector3f::Zero(), std::numeric_limits<float>::infinity(), out);
  EXPECT_EQ(out, std::vector<int>{2});
}

TEST(SpatialHash, NegativeCoordinatesAndFarPoints) {
  // Cells straddling zero and points far outside the packed coordinate range stay exact.
  const std::vector<Eigen::Vector3f> points = {
      {-0.0001f, -0.0001f, -0.0001f}, {0.0001f, 0.0001f, 0.0001f}, {1e6f, 0.f, 0.f}, {1.1e6f, 0.f, 0.f}};
  SpatialHash hash(0.01f);
  hash.build(points);
  EXPECT_EQ(hash.nearest(Eigen::Vector3f(-0.00005f, -0.0001f, -0.0001f), 0.01f), 0);
  EXPECT_EQ(hash.nearest(Eigen::Vector3f(0.00005f, 0.0001f, 0.0001f), 0.01f), 1);
  EXPECT_EQ(hash.nearest(Eigen::Vector3f(1.1e6f, 0.f, 0.f), 1.f), 3);
  EXPECT_EQ(hash.nearest(Eigen::Vector3f(1.05e6f, 0.f, 0.f), 1.f), -1);
}

TEST(SpatialHash, RebuildReplacesPoints) {
  SpatialHash hash(0.01f);
  hash.build(random_points(100, 0.1f, 5));
  const std::vector<Eigen::Vector3f> points = {{1.f, 1.f, 1.f}};
  hash.build(points);
  EXPECT_EQ(hash.size(), 1u);
  EXPECT_EQ(hash.nearest(Eigen::Vector3f::Zero(), 0.2f), -1);
  EXPECT_EQ(hash.nearest(Eigen::Vector3f(1.f, 1.f, 1.005f), 0.01f), 0);
}

}  // namespace
}  // namespace mfot
