#include <gtest/gtest.h>

#include "mfot/model_contact.hpp"
#include "synthetic_object.hpp"

namespace mfot {
namespace {

// Two 10 cm cubes side by side along x, `gap` metres between their facing faces.
struct TwoCubes {
  ObjectModel model = test::make_model(test::make_colored_box(Eigen::Vector3f::Constant(0.1f), 0.005f));
  static constexpr float kRadius = 0.0867f;  // half the cube's diagonal, metres
  PlacedModel first() const {
    return {1, &model, test::make_pose(Eigen::Vector3f(0.f, 0.f, 1.f), Eigen::Vector3f::UnitZ(), 0.f), kRadius};
  }
  PlacedModel at_gap(float gap) const {
    return {2, &model, test::make_pose(Eigen::Vector3f(0.1f + gap, 0.f, 1.f), Eigen::Vector3f::UnitZ(), 0.f), kRadius};
  }
};

TEST(ModelContact, ModelsTouchWithinTheDistanceOnly) {
  const TwoCubes cubes;
  ModelContact contact;
  EXPECT_TRUE(contact.models_touch(cubes.first(), cubes.at_gap(0.004f), 0.01f));
  EXPECT_TRUE(contact.models_touch(cubes.at_gap(0.004f), cubes.first(), 0.01f));  // either order
  EXPECT_FALSE(contact.models_touch(cubes.first(), cubes.at_gap(0.015f), 0.01f));
  EXPECT_TRUE(contact.models_touch(cubes.first(), cubes.at_gap(0.015f), 0.02f));
}

TEST(ModelContact, ATurnBringsACornerIntoContact) {
  // 2 cm apart, face to face: no contact at 1 cm; the second cube turned 45 degrees about z reaches 2.07 cm nearer.
  const TwoCubes cubes;
  ModelContact contact;
  PlacedModel second = cubes.at_gap(0.02f);
  EXPECT_FALSE(contact.models_touch(cubes.first(), second, 0.01f));
  second.pose = test::make_pose(second.pose.translation, Eigen::Vector3f::UnitZ(), test::radians(45.f));
  EXPECT_TRUE(contact.models_touch(cubes.first(), second, 0.01f));
}

TEST(ModelContact, TouchingIsMemoisedWithinAFrame) {
  const TwoCubes cubes;
  ModelContact contact;
  EXPECT_TRUE(contact.touching(cubes.first(), cubes.at_gap(0.004f), 0.01f));
  // Same pair and distance, poses moved apart: the frame's answer stands until new_frame().
  EXPECT_TRUE(contact.touching(cubes.at_gap(0.3f), cubes.first(), 0.01f));
  EXPECT_FALSE(contact.touching(cubes.first(), cubes.at_gap(0.3f), 0.02f));  // another distance: tested
  contact.new_frame();
  EXPECT_FALSE(contact.touching(cubes.first(), cubes.at_gap(0.3f), 0.01f));
}

TEST(ModelContact, BoundingSpheresDecideFarPairsWithoutTheModels) {
  // Radii that understate the models: the spheres say apart although the models touch (the caller's radii bound
  // the models; here they do not, which shows the prefilter answers alone).
  const TwoCubes cubes;
  ModelContact contact;
  PlacedModel a = cubes.first(), b = cubes.at_gap(0.004f);
  a.radius = 0.01f;
  b.radius = 0.01f;
  EXPECT_TRUE(contact.models_touch(a, b, 0.01f));
  EXPECT_FALSE(contact.touching(a, b, 0.01f));
}

TEST(ModelContact, OverlapShareIsTheSmallerModelsShareNearTheOther) {
  const TwoCubes cubes;
  ModelContact contact;
  PlacedModel copy = cubes.first();
  copy.id = 2;
  EXPECT_FLOAT_EQ(contact.overlap_share(cubes.first(), copy, 0.01f), 1.f);  // one space
  // Touching faces: the facing face (one of six) and the rims of the four beside it.
  const float touching = contact.overlap_share(cubes.first(), cubes.at_gap(0.004f), 0.01f);
  EXPECT_GE(touching, 1.f / 6.f);
  EXPECT_LT(touching, 0.3f);
  EXPECT_FLOAT_EQ(contact.overlap_share(cubes.first(), cubes.at_gap(0.3f), 0.01f), 0.f);
  // A model of one face (the cube's first 100 points, its -x face) inside the whole cube: all of the smaller.
  ObjectModel face = cubes.model;
  face.cloud.positions.resize(100);
  face.cloud.colors.resize(100);
  face.features.resize(100);
  const PlacedModel part{3, &face, cubes.first().pose, TwoCubes::kRadius};
  EXPECT_FLOAT_EQ(contact.overlap_share(cubes.first(), part, 0.01f), 1.f);
  EXPECT_FLOAT_EQ(contact.overlap_share(part, cubes.first(), 0.01f), 1.f);
}

}  // namespace
}  // namespace mfot
