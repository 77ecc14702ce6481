#include <gtest/gtest.h>

#include <cstdint>
#include <numeric>
#include <random>
#include <stdexcept>
#include <vector>

#include "mfot/individuation.hpp"

namespace mfot {
namespace {

float uniform01(std::mt19937_64& rng) { return static_cast<float>(rng() >> 40) * 0x1.0p-24f; }

// A dense blob: a g x g x g lattice with 5 mm spacing starting at origin.
void add_blob(std::vector<Eigen::Vector3f>& points, const Eigen::Vector3f& origin, int g) {
  for (int x = 0; x < g; ++x)
    for (int y = 0; y < g; ++y)
      for (int z = 0; z < g; ++z) points.push_back(origin + Eigen::Vector3f(x, y, z) * 0.005f);
}

EuclideanClusterOptions cluster_options(float tolerance, std::size_t min_size) {
  EuclideanClusterOptions o;
  o.tolerance = tolerance;
  o.min_cluster_size = min_size;
  return o;
}

// Brute-force connected components (union-find over all pairs), labelled by lowest member.
std::vector<int> brute_components(const std::vector<Eigen::Vector3f>& points, float tolerance) {
  std::vector<int> parent(points.size());
  std::iota(parent.begin(), parent.end(), 0);
  const auto find = [&](int i) {
    while (parent[static_cast<std::size_t>(i)] != i) i = parent[static_cast<std::size_t>(i)];
    return i;
  };
  for (std::size_t i = 0; i < points.size(); ++i)
    for (std::size_t j = i + 1; j < points.size(); ++j)
      if ((points[i] - points[j]).squaredNorm() <= tolerance * tolerance) {
        const int a = find(static_cast<int>(i)), b = find(static_cast<int>(j));
        parent[static_cast<std::size_t>(std::max(a, b))] = std::min(a, b);
      }
  std::vector<int> root(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) root[i] = find(static_cast<int>(i));
  return root;
}

TEST(EuclideanClustering, RejectsInvalidOptions) {
  EXPECT_THROW(EuclideanClusterer(cluster_options(0.f, 1)), std::invalid_argument);
  EXPECT_THROW(EuclideanClusterer(cluster_options(0.01f, 0)), std::invalid_argument);
}

TEST(EuclideanClustering, SeparatesBlobsAndDropsClustersBelowTheMinimum) {
  std::vector<Eigen::Vector3f> points;
  add_blob(points, {0.f, 0.f, 0.8f}, 4);   // 64 points, indices 0..63
  add_blob(points, {0.1f, 0.f, 0.8f}, 5);  // 125 points, 64..188
  points.push_back({-0.1f, 0.f, 0.8f});    // isolated, 189
  add_blob(points, {0.f, 0.1f, 0.8f}, 3);  // 27 points, 190..216
  points.push_back({0.02f, 0.f, 0.8f});    // 5 mm from the first blob's far corner row: joins it, 217

  EuclideanClusterer clusterer(cluster_options(0.006f, 20));
  ClusterSet clusters;
  clusterer.cluster(points, clusters);
  ASSERT_EQ(clusters.size(), 3u);  // the single point is too small; no blob is too large
  ASSERT_EQ(clusters.cluster(0).size(), 65u);
  EXPECT_EQ(clusters.cluster(0).front(), 0);
  EXPECT_EQ(clusters.cluster(0).back(), 217);
  ASSERT_EQ(clusters.cluster(1).size(), 125u);
  EXPECT_EQ(clusters.cluster(1).front(), 64);
  ASSERT_EQ(clusters.cluster(2).size(), 27u);
  EXPECT_EQ(clusters.cluster(2).front(), 190);
  EXPECT_EQ(clusters.cluster_of_point[100], 1);
  EXPECT_EQ(clusters.cluster_of_point[189], -1);
  EXPECT_EQ(clusters.cluster_of_point[200], 2);

  // A tolerance below the lattice spacing shatters everything into dropped singletons.
  EuclideanClusterer fine(cluster_options(0.004f, 2));
  fine.cluster(points, clusters);
  EXPECT_EQ(clusters.size(), 0u);
}

TEST(EuclideanClustering, MatchesBruteForceComponents) {
  std::mt19937_64 rng(3);
  std::vector<Eigen::Vector3f> points(1500);
  for (auto& p : points) p = Eigen::Vector3f(uniform01(rng), uniform01(rng), uniform01(rng) * 0.05f) * 0.4f;
  const float tolerance = 0.012f;
  const auto roots = brute_components(points, tolerance);
  EuclideanClusterer clusterer(cluster_options(tolerance, 1));
  ClusterSet clusters;
  clusterer.cluster(points, clusters);
  std::size_t covered = 0;
  for (std::size_t k = 0; k < clusters.size(); ++k) {
    const auto members = clusters.cluster(k);
    covered += members.size();
    for (const int i : members) {
      EXPECT_EQ(roots[static_cast<std::size_t>(i)], members.front());
      EXPECT_EQ(clusters.cluster_of_point[static_cast<std::size_t>(i)], static_cast<std::int32_t>(k));
    }
    if (k > 0) {
      EXPECT_LT(clusters.cluster(k - 1).front(), members.front());
    }
  }
  EXPECT_EQ(covered, points.size());
  EXPECT_GT(clusters.size(), 1u);
  EXPECT_LT(clusters.size(), points.size());
}

TEST(Individuation, UnassignedShares) {
  ClusterSet clusters;
  clusters.point_indices = {0, 1, 2, 3, 4};
  clusters.offsets = {0, 3, 5};
  clusters.cluster_of_point = {0, 0, 0, 1, 1};
  const std::vector<std::int32_t> labels = {0, 2, 0, 1, 1};
  std::vector<float> shares;
  unassigned_shares(clusters, labels, shares);
  ASSERT_EQ(shares.size(), 2u);
  EXPECT_FLOAT_EQ(shares[0], 2.f / 3.f);
  EXPECT_FLOAT_EQ(shares[1], 0.f);
}

struct Frame {
  std::vector<Eigen::Vector3f> points;
  std::vector<std::int32_t> labels;
  ClusterSet clusters;
};

// A tracked object's blob (labelled 1) at x = 0, and optionally an unlabelled blob at new_x.
Frame make_frame(bool with_new, float new_x) {
  Frame f;
  add_blob(f.points, {0.f, 0.f, 0.8f}, 4);
  f.labels.assign(f.points.size(), 1);
  if (with_new) {
    add_blob(f.points, {new_x, 0.f, 0.8f}, 4);
    f.labels.resize(f.points.size(), 0);
    f.labels[f.labels.size() - 1] = 1;  // a few points assigned do not make it explained
  }
  EuclideanClusterer(cluster_options(0.006f, 10)).cluster(f.points, f.clusters);
  return f;
}

NewObjectOptions new_object_options(int confirm_frames) {
  NewObjectOptions o;
  o.confirm_frames = confirm_frames;
  return o;
}

TEST(Individuation, NewObjectNeedsPersistence) {
  EXPECT_THROW(NewObjectDetector(new_object_options(0)), std::invalid_argument);
  NewObjectDetector detector(new_object_options(3));
  std::vector<int> confirmed;
  // The unexplained blob drifts 4 mm per frame: within match_distance, so it is one candidate.
  for (int t = 0; t < 2; ++t) {
    Frame f = make_frame(true, 0.1f + 0.004f * static_cast<float>(t));
    detector.update(f.points, f.clusters, f.labels, confirmed);
    EXPECT_TRUE(confirmed.empty()) << t;
    ASSERT_EQ(detector.candidates().size(), 1u);
    EXPECT_EQ(detector.candidates()[0].frames, t + 1);
    EXPECT_EQ(detector.candidates()[0].key, 0u);
  }
  Frame f = make_frame(true, 0.108f);
  detector.update(f.points, f.clusters, f.labels, confirmed);
  ASSERT_EQ(confirmed.size(), 1u);
  EXPECT_EQ(f.clusters.cluster(static_cast<std::size_t>(confirmed[0])).front(), 64);  // the unlabelled blob
  EXPECT_TRUE(detector.candidates().empty());
}

TEST(Individuation, InterruptedOrJumpingCandidatesStartOver) {
  NewObjectDetector detector(new_object_options(3));
  std::vector<int> confirmed;
  const auto step = [&](bool with_new, float x) {
    Frame f = make_frame(with_new, x);
    detector.update(f.points, f.clusters, f.labels, confirmed);
    return confirmed.size();
  };
  EXPECT_EQ(step(true, 0.1f), 0u);
  EXPECT_EQ(step(true, 0.1f), 0u);
  EXPECT_EQ(step(false, 0.f), 0u);  // gone for a frame: the candidate is dropped
  EXPECT_TRUE(detector.candidates().empty());
  EXPECT_EQ(step(true, 0.1f), 0u);
  EXPECT_EQ(step(true, 0.2f), 0u);  // jumped 10 cm: no overlap, a new candidate
  ASSERT_EQ(detector.candidates().size(), 1u);
  EXPECT_EQ(detector.candidates()[0].frames, 1);
  EXPECT_EQ(step(true, 0.2f), 0u);
  EXPECT_EQ(step(true, 0.2f), 1u);
}

TEST(Individuation, ExplainedClustersNeverBecomeObjects) {
  NewObjectDetector detector(new_object_options(1));
  std::vector<int> confirmed;
  Frame f = make_frame(false, 0.f);
  detector.update(f.points, f.clusters, f.labels, confirmed);
  EXPECT_TRUE(confirmed.empty());
  f = make_frame(true, 0.1f);  // confirm_frames = 1: confirmed at once
  detector.update(f.points, f.clusters, f.labels, confirmed);
  EXPECT_EQ(confirmed, std::vector<int>{1});
}

TEST(Individuation, SupportMonitorRetiresAfterConsecutiveMisses) {
  SupportLossOptions options;
  options.min_points = 20;
  options.max_frames = 3;
  SupportMonitor monitor(options);
  std::vector<std::int32_t> retired;
  const std::vector<std::int32_t> ids = {4, 7};
  const auto step = [&](std::size_t a, std::size_t b) {
    const std::vector<std::size_t> counts = {a, b};
    monitor.update(ids, counts, {}, retired);
    return retired;
  };
  EXPECT_TRUE(step(100, 5).empty());
  EXPECT_TRUE(step(19, 5).empty());
  EXPECT_EQ(monitor.frames_without_support(7), 2);
  EXPECT_EQ(monitor.frames_without_support(4), 1);
  EXPECT_TRUE(step(20, 100).empty());  // both recover: counters reset
  EXPECT_EQ(monitor.frames_without_support(7), 0);
  EXPECT_TRUE(step(0, 0).empty());
  EXPECT_TRUE(step(0, 0).empty());
  EXPECT_EQ(step(0, 50), std::vector<std::int32_t>{4});
  EXPECT_EQ(monitor.frames_without_support(4), 0);

  SupportLossOptions invalid;
  invalid.max_frames = 0;
  EXPECT_THROW(SupportMonitor{invalid}, std::invalid_argument);
}

TEST(Individuation, SupportMonitorDoesNotCountHiddenFrames) {
  SupportLossOptions options;
  options.min_points = 20;
  options.max_frames = 2;
  SupportMonitor monitor(options);
  std::vector<std::int32_t> retired;
  const std::vector<std::int32_t> ids = {4, 7};
  const std::vector<std::size_t> none = {0, 0};
  const std::vector<std::uint8_t> seven_hidden = {0, 1};
  monitor.update(ids, none, seven_hidden, retired);
  EXPECT_TRUE(retired.empty());
  EXPECT_EQ(monitor.frames_without_support(4), 1);
  EXPECT_EQ(monitor.frames_without_support(7), 0);
  for (int t = 0; t < 10 && retired.empty(); ++t)
    monitor.update(std::vector<std::int32_t>{7}, std::vector<std::size_t>{0}, std::vector<std::uint8_t>{1}, retired);
  EXPECT_TRUE(retired.empty());  // hidden for 10 frames: still there
  // A frame without support that is not hidden counts again; hidden ones keep the count.
  monitor.update(std::vector<std::int32_t>{7}, std::vector<std::size_t>{0}, std::vector<std::uint8_t>{0}, retired);
  monitor.update(std::vector<std::int32_t>{7}, std::vector<std::size_t>{0}, std::vector<std::uint8_t>{1}, retired);
  EXPECT_EQ(monitor.frames_without_support(7), 1);
  monitor.update(std::vector<std::int32_t>{7}, std::vector<std::size_t>{0}, std::vector<std::uint8_t>{0}, retired);
  EXPECT_EQ(retired, std::vector<std::int32_t>{7});
  EXPECT_THROW(monitor.update(ids, none, std::vector<std::uint8_t>{1}, retired), std::invalid_argument);
}

}  // namespace
}  // namespace mfot
