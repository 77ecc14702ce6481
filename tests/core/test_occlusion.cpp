#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <vector>

#include "mfot/occlusion.hpp"

namespace mfot {
namespace {

// A square patch on a 5 mm lattice facing the camera (z = depth), centred on the optical axis.
std::vector<Eigen::Vector3f> facing_patch(float depth, int n = 20, float x0 = 0.f) {
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      points.emplace_back(x0 + (static_cast<float>(i) - 0.5f * static_cast<float>(n - 1)) * 0.005f,
                          (static_cast<float>(j) - 0.5f * static_cast<float>(n - 1)) * 0.005f, depth);
  return points;
}

Pose identity() { return Pose{}; }

TEST(OcclusionTest, RejectsInvalidOptions) {
  OcclusionOptions o;
  o.window = 0.f;
  EXPECT_THROW(OcclusionTest{o}, std::invalid_argument);
  o = OcclusionOptions{};
  o.depth_margin = -0.01f;
  EXPECT_THROW(OcclusionTest{o}, std::invalid_argument);
  o = OcclusionOptions{};
  o.own_surface_radius = 0.2f;
  EXPECT_THROW(OcclusionTest{o}, std::invalid_argument);
}

TEST(OcclusionTest, AVisibleModelIsNotOccludedAndAnEmptyOneHasShareZero) {
  const auto model = facing_patch(1.0f);
  OcclusionTest test;
  test.set_scene(model);  // the scene is the model's own surface
  EXPECT_EQ(test.occluded_share(model, identity()), 0.f);
  EXPECT_EQ(test.occluded_share({}, identity()), 0.f);
}

TEST(OcclusionTest, SharesFollowTheCoveredPartOfTheModel) {
  const auto model = facing_patch(1.0f);  // x in [-4.75, 4.75] cm
  // A plate 10 cm in front covering the half x < 0 of the model, and the model's own surface.
  std::vector<Eigen::Vector3f> scene = model;
  for (const auto& p : facing_patch(0.9f, 20, -0.05f)) scene.push_back(p);
  OcclusionTest test;
  test.set_scene(scene);
  const float share = test.occluded_share(model, identity());
  EXPECT_GT(share, 0.45f);
  EXPECT_LT(share, 0.6f);
  // Fully behind a large plate.
  test.set_scene(facing_patch(0.8f, 40));
  EXPECT_EQ(test.occluded_share(model, identity()), 1.f);
  // Behind the camera counts as occluded; a surface behind the model never occludes it.
  EXPECT_TRUE(test.occluded(Eigen::Vector3f(0.f, 0.f, -0.1f)));
  test.set_scene(facing_patch(1.2f, 40));
  EXPECT_EQ(test.occluded_share(model, identity()), 0.f);
}

TEST(OcclusionTest, TheObjectsOwnNearSideNeverHidesItsFarSide) {
  // A two-sided model: a front face at 1.00 m and a back face at 1.04 m, both in the scene.
  std::vector<Eigen::Vector3f> model = facing_patch(1.0f);
  for (const auto& p : facing_patch(1.04f)) model.push_back(p);
  OcclusionTest test;
  test.set_scene(facing_patch(1.0f));
  EXPECT_EQ(test.occluded_share(model, identity()), 0.f);
  // Without the own-surface rule the front face hides the back face: half the model.
  OcclusionOptions plain;
  plain.own_surface_radius = 0.f;
  OcclusionTest plain_test(plain);
  plain_test.set_scene(facing_patch(1.0f));
  EXPECT_NEAR(plain_test.occluded_share(model, identity()), 0.5f, 1e-6f);
}

TEST(OcclusionTest, MovesTheModelByThePose) {
  const auto model = facing_patch(0.f);  // object frame: the patch at the origin
  Pose pose;
  pose.translation = Eigen::Vector3f(0.f, 0.f, 1.f);
  OcclusionTest test;
  test.set_scene(facing_patch(0.9f, 40));
  EXPECT_EQ(test.occluded_share(model, pose), 1.f);
  pose.translation.z() = 0.85f;  // now in front of the plate
  EXPECT_EQ(test.occluded_share(model, pose), 0.f);
}

TEST(OcclusionTest, TheSceneIsSeenThroughWhereTheModelIsNotAnyMore) {
  // A two-sided model (front face at 1.00 m, back face at 1.04 m) whose front face the scene shows.
  std::vector<Eigen::Vector3f> model = facing_patch(1.0f);
  for (const auto& p : facing_patch(1.04f)) model.push_back(p);
  OcclusionTest test;
  test.set_scene(facing_patch(1.0f));
  test.set_model(model, identity());
  EXPECT_EQ(test.seen_through_share(), 0.f);  // its front face is there and covers its back face
  // Behind a plate: hidden, not seen through.
  test.set_scene(facing_patch(0.8f, 40));
  test.set_model(model, identity());
  EXPECT_EQ(test.seen_through_share(), 0.f);
  // Gone: a wall 30 cm behind, or nothing at all (a removed table), is seen where it was.
  test.set_scene(facing_patch(1.3f, 40));
  test.set_model(model, identity());
  EXPECT_EQ(test.seen_through_share(), 1.f);
  test.set_scene({});
  test.set_model(model, identity());
  EXPECT_EQ(test.seen_through_share(), 1.f);
  // Half of the front face there (x < 0): the other half of both faces is seen through.
  std::vector<Eigen::Vector3f> half;
  for (const auto& p : facing_patch(1.0f)) {
    if (p.x() < 0.f) half.push_back(p);
  }
  test.set_scene(half);
  test.set_model(model, identity());
  EXPECT_GT(test.seen_through_share(), 0.4f);
  EXPECT_LT(test.seen_through_share(), 0.55f);
  // Within depth_margin behind a model point still counts as its own surface (a box 8 mm off).
  test.set_scene(facing_patch(1.008f));
  test.set_model(facing_patch(1.0f), identity());
  EXPECT_EQ(test.seen_through_share(), 0.f);
  test.set_model({}, identity());
  EXPECT_EQ(test.seen_through_share(), 0.f);
}

// The posed, strided form compares poses without set_model: equal to set_model + seen_through_share() on every
// point, a stride's share close to it, and the set model left as it was.
TEST(OcclusionTest, TheSeenThroughShareOfAPoseNeedsNoSetModel) {
  std::vector<Eigen::Vector3f> half;
  for (const auto& p : facing_patch(1.0f)) {
    if (p.x() < 0.f) half.push_back(p);
  }
  const std::vector<Eigen::Vector3f> model = facing_patch(0.f);  // object frame: 1 m ahead at the pose below
  Pose ahead;
  ahead.translation = Eigen::Vector3f(0.f, 0.f, 1.f);
  Pose aside = ahead;
  aside.translation.x() = -0.2f;  // wholly over the half the scene shows
  OcclusionTest test;
  test.set_scene(half);
  test.set_model(model, ahead);
  const float full = test.seen_through_share();
  EXPECT_GT(full, 0.3f);  // the half beyond the scene's edge, less a cone's width along it
  EXPECT_LT(full, 0.55f);
  EXPECT_EQ(test.seen_through_share(model, ahead, static_cast<int>(model.size())), full);
  EXPECT_NEAR(test.seen_through_share(model, ahead, 100), full, 0.05f);
  EXPECT_EQ(test.seen_through_share(model, aside, 100), 1.f);  // nothing there: a removed table
  EXPECT_EQ(test.seen_through_share(model, ahead, 1), test.seen_through_share(std::span(model).first(1), ahead, 1));
  EXPECT_EQ(test.seen_through_share({}, ahead, 10), 0.f);
  EXPECT_EQ(test.seen_through_share(), full);  // the set model is untouched
  EXPECT_THROW(test.seen_through_share(model, ahead, 0), std::invalid_argument);
}

// Outside the image the camera sees nothing, so nothing there is seen through: with nothing in the scene, the
// model is seen through where the view covers it (x/z >= 0 here: half the patch) and nowhere once it lies
// wholly outside; without a view every point counts as in it.
TEST(OcclusionTest, NothingOutsideTheViewIsSeenThrough) {
  const std::vector<Eigen::Vector3f> model = facing_patch(1.0f);
  OcclusionTest test;
  test.set_scene({});
  test.set_view(ViewBounds{0.f, 1.f, -1.f, 1.f});
  test.set_model(model, identity());
  EXPECT_GT(test.seen_through_share(), 0.4f);
  EXPECT_LT(test.seen_through_share(), 0.6f);
  test.set_view(ViewBounds{2.f, 3.f, -1.f, 1.f});
  EXPECT_EQ(test.seen_through_share(), 0.f);
  test.set_view(std::nullopt);
  EXPECT_EQ(test.seen_through_share(), 1.f);
  // An image's view: pixel edges through the intrinsics.
  const ViewBounds image = ViewBounds::of_image(640, 480, 500.f, 400.f, 319.5f, 239.5f);
  EXPECT_FLOAT_EQ(image.x_min, -320.f / 500.f);
  EXPECT_FLOAT_EQ(image.x_max, 320.f / 500.f);
  EXPECT_FLOAT_EQ(image.y_min, -240.f / 400.f);
  EXPECT_FLOAT_EQ(image.y_max, 240.f / 400.f);
  EXPECT_TRUE(image.contains(0.63f, -0.59f));
  EXPECT_FALSE(image.contains(0.65f, 0.f));
}

HypothesisData as_data(const std::vector<Eigen::Vector3f>& points) {
  HypothesisData data;
  for (std::size_t k = 0; k < points.size(); ++k) {
    data.points.push_back(points[k]);
    data.features.push_back(SmrFeature{});
    data.features.back().gray_weight = static_cast<float>(k);  // tags each point's feature
    data.colors.push_back(Rgb8{static_cast<std::uint8_t>(k % 256), 0, 0});
  }
  return data;
}

TEST(OcclusionTest, RemovesThePointsInFrontOfTheModelAndKeepsTheRestInOrder) {
  const auto model = facing_patch(1.0f);  // 20 x 20 points, x in [-4.75, 4.75] cm
  // Data: the model's visible surface (400 points), a plate 10 cm in front over the half x < 0
  // (a hand: 400 points, about half of them in front of the model), a surface behind the model.
  std::vector<Eigen::Vector3f> points = model;
  const auto plate = facing_patch(0.9f, 20, -0.05f);
  points.insert(points.end(), plate.begin(), plate.end());
  const auto behind = facing_patch(1.2f, 4);
  points.insert(points.end(), behind.begin(), behind.end());
  HypothesisData data = as_data(points);
  OcclusionTest test;
  test.set_model(model, identity());
  const std::size_t removed = test.remove_occluders(data);
  // The plate's points on rays through the model go; its points beside the model, the model's own
  // surface and the surface behind it stay.
  std::size_t in_front = 0;
  for (const auto& p : plate) in_front += std::abs(p.x() / p.z()) < 0.0475f / 1.0f + 0.006f ? 1 : 0;
  EXPECT_GT(removed, 150u);
  EXPECT_LE(removed, in_front);
  ASSERT_EQ(data.points.size(), points.size() - removed);
  ASSERT_EQ(data.features.size(), data.points.size());
  ASSERT_EQ(data.colors.size(), data.points.size());
  for (std::size_t k = 0; k < model.size(); ++k) EXPECT_EQ(data.points[k], model[k]);  // first, in order
  float last_tag = -1.f;
  for (std::size_t k = 0; k < data.points.size(); ++k) {
    const float tag = data.features[k].gray_weight;
    EXPECT_GT(tag, last_tag);
    EXPECT_EQ(points[static_cast<std::size_t>(tag)], data.points[k]);  // feature travelled with its point
    last_tag = tag;
    EXPECT_FALSE(data.points[k].z() < 0.95f && std::abs(data.points[k].x()) < 0.04f) << "a point in front stayed";
  }
  for (const auto& p : behind) {
    EXPECT_NE(std::find(data.points.begin(), data.points.end(), p), data.points.end());
  }
}

TEST(OcclusionTest, RemovingOccludersSparesTheObjectsOwnNearSideAndFollowsThePose) {
  // A two-sided model (front 1.00 m, back 1.04 m): the observed front face occludes the back face
  // but is the object's own surface.
  std::vector<Eigen::Vector3f> model = facing_patch(0.f);
  for (const auto& p : facing_patch(0.04f)) model.push_back(p);
  Pose pose;
  pose.translation = Eigen::Vector3f(0.f, 0.f, 1.f);
  HypothesisData data = as_data(facing_patch(1.0f));
  OcclusionTest test;
  test.set_model(model, pose);
  EXPECT_EQ(test.remove_occluders(data), 0u);
  EXPECT_EQ(data.points.size(), 400u);
  // Without the own-surface rule the front face counts as an occluder of the back face.
  OcclusionOptions plain;
  plain.own_surface_radius = 0.f;
  OcclusionTest plain_test(plain);
  plain_test.set_model(model, pose);
  EXPECT_EQ(plain_test.remove_occluders(data), 400u);
  // The model moved 20 cm back: a surface at 1 m within its silhouette is now in front of it.
  data = as_data(facing_patch(1.0f, 16));
  pose.translation.z() = 1.2f;
  test.set_model(model, pose);
  EXPECT_EQ(test.remove_occluders(data), 256u);
  EXPECT_TRUE(data.points.empty() && data.features.empty() && data.colors.empty());
  // Nothing to remove from, or nothing to be occluded.
  test.set_model({}, pose);
  EXPECT_EQ(test.remove_occluders(data), 0u);
}

}  // namespace
}  // namespace mfot
