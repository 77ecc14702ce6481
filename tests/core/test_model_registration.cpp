#include <gtest/gtest.h>

#include <stdexcept>

#include "mfot/model_registration.hpp"
#include "synthetic_object.hpp"

namespace mfot {
namespace {

// The textured test box at pose, seen by a camera at the origin: its other sampling (no point shared
// with the model), its near side.
HypothesisData seen_box(const Pose& pose) {
  return test::make_hypothesis(
      test::seen_from_origin(test::make_test_object(0.5f, 0.008f, true), Eigen::Vector3f(0.10f, 0.15f, 0.08f), pose));
}

TEST(ModelRegistration, FindsAKnownModelTurnedAnyWayOnTheNearSideItShows) {
  const ObjectModel model = test::make_model(test::make_test_object(0.f, 0.008f, true));
  ModelRegistration registration;
  const std::array<std::pair<Eigen::Vector3f, float>, 4> turns{
      std::pair{Eigen::Vector3f(0.f, 0.f, 1.f), 0.3f}, std::pair{Eigen::Vector3f(1.f, 0.f, 0.f), 2.0f},
      std::pair{Eigen::Vector3f(1.f, 1.f, 0.f), -1.2f}, std::pair{Eigen::Vector3f(0.3f, -1.f, 0.5f), 2.8f}};
  for (const auto& [axis, angle] : turns) {
    const Pose truth = test::make_pose(Eigen::Vector3f(0.1f, -0.05f, 0.9f), axis, angle);
    const auto found = registration.register_model(model, seen_box(truth));
    ASSERT_TRUE(found.has_value()) << axis.transpose() << " " << angle;
    EXPECT_LT(test::degrees(test::rotation_error(found->pose, truth)), 3.f) << axis.transpose() << " " << angle;
    // Within the 5 mm voxel: the score's peak moves with how the points sample the faces.
    EXPECT_LT(test::translation_error(found->pose, truth), 0.006f) << axis.transpose() << " " << angle;
    EXPECT_GE(found->fit, registration.options().min_fit);
  }
}

TEST(ModelRegistration, HoldsNoGridBetweenRegistrationsOverManyOfThem) {
  // A long run registers many objects seen again: the memory held between registrations must not
  // keep the largest model's grid (megabytes) for ever.
  ModelRegistration registration;
  EXPECT_TRUE(registration.grid().empty());
  const ObjectModel model = test::make_model(test::make_test_object(0.f, 0.008f, true));
  const ObjectModel grey = test::make_model(test::make_test_object(0.f, 0.008f, false));
  for (int i = 0; i < 20; ++i) {
    const Pose truth = test::make_pose(Eigen::Vector3f(0.1f, -0.05f, 0.9f), Eigen::Vector3f(0.f, 0.f, 1.f),
                                       0.1f * static_cast<float>(i));
    // Found or not (another object's colours), no grid stays.
    registration.register_model(i % 2 == 0 ? model : grey, seen_box(truth));
    EXPECT_TRUE(registration.grid().empty()) << "registration " << i;
    EXPECT_TRUE(registration.grid().values.capacity() == 0) << "registration " << i;
  }
}

TEST(ModelRegistration, AnotherObjectHasNoRegistration) {
  const ObjectModel model = test::make_model(test::make_test_object(0.f, 0.008f, true));
  // A box of the same shape in one colour: nothing of the model's texture.
  const ColoredCloud grey =
      test::make_colored_box(Eigen::Vector3f(0.10f, 0.15f, 0.08f), 0.008f,
                             {test::kWhite, test::kWhite, test::kWhite, test::kWhite, test::kWhite, test::kWhite});
  const Pose pose = test::make_pose(Eigen::Vector3f(0.f, 0.f, 1.f), Eigen::Vector3f::UnitZ(), 0.4f);
  ModelRegistration registration;
  EXPECT_FALSE(registration.register_model(model, test::make_hypothesis(test::transformed(grey, pose))).has_value());
  EXPECT_FALSE(registration.register_model(model, HypothesisData{}).has_value());
}

TEST(ModelRegistration, IsDeterministicAndTriesThePriorFirst) {
  const ObjectModel model = test::make_model(test::make_test_object(0.f, 0.008f, true));
  const Pose truth = test::make_pose(Eigen::Vector3f(0.f, 0.05f, 1.f), Eigen::Vector3f(1.f, 0.f, 1.f), 1.0f);
  const HypothesisData data = seen_box(truth);
  ModelRegistrationOptions one;
  one.rotations = 1;  // a single random rotation: only the prior can lead to the truth
  ModelRegistration a(one), b(one);
  const auto with_prior = a.register_model(model, data, truth.rotation);
  ASSERT_TRUE(with_prior.has_value());
  EXPECT_LT(test::degrees(test::rotation_error(with_prior->pose, truth)), 2.f);
  const auto again = b.register_model(model, data, truth.rotation);
  ASSERT_TRUE(again.has_value());
  EXPECT_EQ(again->pose.translation, with_prior->pose.translation);
  EXPECT_EQ(again->pose.rotation.coeffs(), with_prior->pose.rotation.coeffs());
}

TEST(ModelRegistration, RejectsBadOptionsAndInput) {
  ModelRegistrationOptions o;
  o.rotations = 0;
  EXPECT_THROW(ModelRegistration{o}, std::invalid_argument);
  o = {};
  o.candidates = 0;
  EXPECT_THROW(ModelRegistration{o}, std::invalid_argument);
  o = {};
  o.min_fit = 1.5f;
  EXPECT_THROW(ModelRegistration{o}, std::invalid_argument);
  o = {};
  o.fit.match_distance = 0.f;
  EXPECT_THROW(ModelRegistration{o}, std::invalid_argument);
  HypothesisData data = seen_box(test::make_pose(Eigen::Vector3f(0.f, 0.f, 1.f), Eigen::Vector3f::UnitZ(), 0.f));
  data.features.clear();
  ModelRegistration registration;
  EXPECT_THROW(registration.register_model(test::make_model(test::make_test_object()), data), std::invalid_argument);
}

}  // namespace
}  // namespace mfot
