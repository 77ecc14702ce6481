#include "mfot/occlusion.hpp"

#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

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

}  // namespace
}  // namespace mfot
