#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

#include "mfot/segmentation.hpp"

namespace mfot {
namespace {

float uniform01(std::mt19937_64& rng) { return static_cast<float>(rng() >> 40) * 0x1.0p-24f; }

std::vector<Eigen::Vector3f> random_points(std::size_t n, float extent, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<Eigen::Vector3f> points(n);
  for (auto& p : points) p = Eigen::Vector3f(uniform01(rng), uniform01(rng), uniform01(rng)) * extent;
  return points;
}

Pose make_pose(const Eigen::Vector3f& t, float angle, const Eigen::Vector3f& axis) {
  Pose pose;
  pose.translation = t;
  pose.rotation = Eigen::Quaternionf(Eigen::AngleAxisf(angle, axis.normalized()));
  return pose;
}

// Surface samples of an axis-aligned box centred at the origin, on a grid of the given step
// shifted by phase; faces listed in skip_faces (0..5 = -x, +x, -y, +y, -z, +z) are left out.
std::vector<Eigen::Vector3f> box_surface(const Eigen::Vector3f& size, float step, float phase,
                                         std::vector<int> skip_faces = {}) {
  std::vector<Eigen::Vector3f> points;
  const Eigen::Vector3f half = size / 2;
  for (int face = 0; face < 6; ++face) {
    if (std::find(skip_faces.begin(), skip_faces.end(), face) != skip_faces.end()) continue;
    const int axis = face / 2;
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    for (float a = -half[u] + phase; a <= half[u]; a += step) {
      for (float b = -half[v] + phase; b <= half[v]; b += step) {
        Eigen::Vector3f p;
        p[axis] = face % 2 == 0 ? -half[axis] : half[axis];
        p[u] = a;
        p[v] = b;
        points.push_back(p);
      }
    }
  }
  return points;
}

TEST(Segmentation, RejectsInvalidOptionsAndIds) {
  EXPECT_THROW(Segmenter(SegmentationOptions{.tau = 0.f}), std::invalid_argument);
  EXPECT_THROW(Segmenter(SegmentationOptions{.tau = std::numeric_limits<float>::quiet_NaN()}), std::invalid_argument);
  Segmenter segmenter;
  const std::vector<Eigen::Vector3f> model = {Eigen::Vector3f::Zero()};
  SegmentationResult result;
  const std::vector<SegmentationObject> zero_id = {{0, model, Pose{}}};
  EXPECT_THROW(segmenter.segment(model, zero_id, result), std::invalid_argument);
  const std::vector<SegmentationObject> repeated = {{3, model, Pose{}}, {3, model, Pose{}}};
  EXPECT_THROW(segmenter.segment(model, repeated, result), std::invalid_argument);
}

TEST(Segmentation, LabelsPointsNearTheModelInItsEstimatedPose) {
  const auto model = random_points(400, 0.1f, 1);  // object frame
  const Pose pose = make_pose({0.1f, -0.05f, 0.9f}, 0.7f, {1.f, 2.f, 3.f});
  std::vector<Eigen::Vector3f> scene;
  for (const auto& p : model) scene.push_back(pose.isometry() * p);
  // Two points far from every model point: 20 cm from model point 0 (more than the model's
  // 17 cm diameter) and one far away.
  scene.push_back(pose.isometry() * model[0] + Eigen::Vector3f(0.f, 0.f, -0.2f));
  scene.push_back(Eigen::Vector3f(2.f, 2.f, 2.f));

  Segmenter segmenter;
  SegmentationResult result;
  const std::vector<SegmentationObject> objects = {{7, model, pose}};
  segmenter.segment(scene, objects, result);
  ASSERT_EQ(result.labels.size(), scene.size());
  for (std::size_t i = 0; i < model.size(); ++i) EXPECT_EQ(result.labels[i], 7) << i;
  EXPECT_EQ(result.labels[model.size()], 0);
  EXPECT_EQ(result.labels[model.size() + 1], 0);
  EXPECT_EQ(result.object_ids, std::vector<std::int32_t>{7});
  EXPECT_EQ(result.counts, std::vector<std::size_t>{model.size()});

  // The same model with the identity pose no longer explains the moved scene.
  const std::vector<SegmentationObject> wrong_pose = {{7, model, Pose{}}};
  segmenter.segment(scene, wrong_pose, result);
  EXPECT_EQ(result.counts[0], 0u);
}

TEST(Segmentation, TauBoundsTheAssignment) {
  const std::vector<Eigen::Vector3f> model = {Eigen::Vector3f::Zero()};
  const std::vector<Eigen::Vector3f> scene = {{0.f, 0.f, 0.0099f}, {0.f, 0.f, 0.0101f}, {0.f, 0.0199f, 0.f}};
  const std::vector<SegmentationObject> objects = {{1, model, Pose{}}};
  SegmentationResult result;
  Segmenter(SegmentationOptions{.tau = 0.01f}).segment(scene, objects, result);
  EXPECT_EQ(result.labels, (std::vector<std::int32_t>{1, 0, 0}));
  Segmenter(SegmentationOptions{.tau = 0.02f}).segment(scene, objects, result);
  EXPECT_EQ(result.labels, (std::vector<std::int32_t>{1, 1, 1}));
}

TEST(Segmentation, MatchesBruteForceOverAllObjectsAtOnce) {
  // Three overlapping random models: each scene point must take the globally closest model.
  std::vector<std::vector<Eigen::Vector3f>> models = {random_points(300, 0.1f, 2), random_points(300, 0.1f, 3),
                                                      random_points(300, 0.1f, 4)};
  const std::vector<Pose> poses = {make_pose({0.f, 0.f, 0.8f}, 0.f, {0.f, 0.f, 1.f}),
                                   make_pose({0.03f, 0.f, 0.8f}, 0.5f, {0.f, 1.f, 0.f}),
                                   make_pose({0.f, 0.04f, 0.82f}, -0.9f, {1.f, 0.f, 1.f})};
  const std::vector<std::int32_t> ids = {5, 2, 9};
  std::vector<SegmentationObject> objects;
  for (std::size_t k = 0; k < models.size(); ++k) objects.push_back({ids[k], models[k], poses[k]});
  auto scene = random_points(3000, 0.18f, 5);
  for (auto& p : scene) p += Eigen::Vector3f(-0.02f, -0.02f, 0.74f);

  Segmenter segmenter(SegmentationOptions{.tau = 0.01f});
  SegmentationResult result;
  segmenter.segment(scene, objects, result);
  std::vector<std::size_t> expected_counts(models.size(), 0);
  std::size_t labelled = 0;
  for (std::size_t i = 0; i < scene.size(); ++i) {
    float best = 0.01f * 0.01f;
    std::int32_t expected = 0;
    std::size_t expected_k = 0;
    for (std::size_t k = 0; k < models.size(); ++k) {
      const Eigen::Isometry3f t = poses[k].isometry();
      for (const auto& m : models[k]) {
        const float d2 = (t * m - scene[i]).squaredNorm();
        if (d2 < best || (d2 == best && expected == 0)) {
          best = d2;
          expected = ids[k];
          expected_k = k;
        }
      }
    }
    ASSERT_EQ(result.labels[i], expected) << i;
    if (expected != 0) {
      ++expected_counts[expected_k];
      ++labelled;
    }
  }
  EXPECT_EQ(result.counts, expected_counts);
  EXPECT_GT(labelled, 100u);
  EXPECT_LT(labelled, scene.size());
}

TEST(Segmentation, ThreadsGiveTheSameLabelsAndCounts) {
  std::vector<std::vector<Eigen::Vector3f>> models = {random_points(300, 0.1f, 6), random_points(300, 0.1f, 7)};
  const std::vector<Pose> poses = {make_pose({0.f, 0.f, 0.8f}, 0.f, {0.f, 0.f, 1.f}),
                                   make_pose({0.04f, 0.f, 0.8f}, 0.7f, {0.f, 1.f, 0.f})};
  std::vector<SegmentationObject> objects = {{3, models[0], poses[0]}, {8, models[1], poses[1]}};
  auto scene = random_points(5001, 0.18f, 8);  // not a multiple of the ranges
  for (auto& p : scene) p += Eigen::Vector3f(-0.02f, -0.02f, 0.74f);
  Segmenter segmenter(SegmentationOptions{.tau = 0.01f});
  SegmentationResult alone, side_by_side;
  segmenter.segment(scene, objects, alone);
  ThreadPool pool(3);
  segmenter.segment(scene, objects, side_by_side, &pool);
  EXPECT_EQ(side_by_side.labels, alone.labels);
  EXPECT_EQ(side_by_side.counts, alone.counts);
  EXPECT_EQ(side_by_side.object_ids, alone.object_ids);
  EXPECT_GT(alone.counts[0], 0u);
  EXPECT_GT(alone.counts[1], 0u);
}

TEST(Segmentation, SplitsTwoTouchingBoxes) {
  // Two 6 x 8 x 5 cm boxes side by side, in contact along their x faces, seen from 0.8 m.
  // Models: full surfaces sampled every 5 mm. Scene: their outer surfaces (the contact faces
  // are hidden) on a different sampling phase with up to 1.5 mm noise.
  const Eigen::Vector3f size(0.06f, 0.08f, 0.05f);
  const auto model = box_surface(size, 0.005f, 0.f);
  const Eigen::Quaternionf tilt(Eigen::AngleAxisf(0.4f, Eigen::Vector3f(1.f, 0.3f, 0.f).normalized()));
  const Eigen::Vector3f centre(0.02f, -0.01f, 0.8f);
  const Eigen::Vector3f axis_x = tilt * Eigen::Vector3f::UnitX();
  Pose left, right;
  left.rotation = right.rotation = tilt;
  left.translation = centre - axis_x * 0.03f;
  right.translation = centre + axis_x * 0.03f;

  std::mt19937_64 rng(11);
  std::vector<Eigen::Vector3f> scene;
  std::vector<std::int32_t> truth;
  std::vector<float> distance_to_contact;
  const auto add_box = [&](const Pose& pose, std::int32_t id, int hidden_face) {
    for (const auto& p : box_surface(size, 0.005f, 0.0025f, {hidden_face})) {
      const Eigen::Vector3f noise =
          (Eigen::Vector3f(uniform01(rng), uniform01(rng), uniform01(rng)) * 2.f - Eigen::Vector3f::Ones()) * 0.0015f /
          std::sqrt(3.f);
      const Eigen::Vector3f q = pose.isometry() * p + noise;
      scene.push_back(q);
      truth.push_back(id);
      distance_to_contact.push_back(std::abs(axis_x.dot(q - centre)));
    }
  };
  add_box(left, 1, 1);   // its +x face touches the right box
  add_box(right, 2, 0);  // its -x face touches the left box

  const std::vector<SegmentationObject> objects = {{1, model, left}, {2, model, right}};
  Segmenter segmenter;
  SegmentationResult result;
  segmenter.segment(scene, objects, result);
  std::size_t correct = 0;
  for (std::size_t i = 0; i < scene.size(); ++i) {
    ASSERT_NE(result.labels[i], 0) << i;
    if (result.labels[i] == truth[i]) {
      ++correct;
    } else {
      EXPECT_LT(distance_to_contact[i], 0.005f) << "mislabelled far from the contact: " << i;
    }
  }
  EXPECT_GE(static_cast<double>(correct) / static_cast<double>(scene.size()), 0.98);
}

TEST(Segmentation, GatherSegmentCopiesOneObject) {
  ColoredCloud scene;
  scene.push_back({0.f, 0.f, 1.f}, {1, 2, 3});
  scene.push_back({1.f, 0.f, 1.f}, {4, 5, 6});
  scene.push_back({2.f, 0.f, 1.f}, {7, 8, 9});
  const std::vector<std::int32_t> labels = {4, 0, 4};
  ColoredCloud out;
  out.push_back({9.f, 9.f, 9.f}, {});
  gather_segment(scene, labels, 4, out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out.positions[1], scene.positions[2]);
  EXPECT_EQ(out.colors[0], scene.colors[0]);
  const std::vector<std::int32_t> short_labels = {4};
  EXPECT_THROW(gather_segment(scene, short_labels, 4, out), std::invalid_argument);
}

}  // namespace
}  // namespace mfot
