#include <gtest/gtest.h>

#include <stdexcept>

#include "expect_invalid_argument.hpp"
#include "mfot/companion_motion.hpp"
#include "mfot/particle_filter.hpp"
#include "synthetic_object.hpp"

namespace mfot {
namespace {

// A hand whose last step moved it 1 cm and turned it 3 degrees about an oblique axis, and a box gripped
// 8 cm from the hand's origin (a fixed pose relative to the hand).
struct Grip {
  Eigen::Isometry3f relative =
      test::make_pose(Eigen::Vector3f(0.08f, -0.02f, 0.01f), Eigen::Vector3f::UnitZ(), 0.4f).isometry();
  Pose hand_before = test::make_pose(Eigen::Vector3f(0.1f, 0.f, 1.f), Eigen::Vector3f(1.f, 0.3f, 0.2f), 0.2f);
  PoseVector hand_step = (PoseVector() << 0.01f, 0.f, -0.002f, 0.02f, -0.04f, 0.03f).finished();
  Pose hand_now = apply_increment(hand_before, hand_step);
  Pose box(const Pose& hand) const { return Pose::from_isometry(hand.isometry() * relative); }
};

TEST(CompanionMotion, AGrippedObjectMovesAsItsCompanionsNextStepMovesIt) {
  const Grip grip;
  const Pose box_now = grip.box(grip.hand_now);
  // The hand's next step predicted as its last one repeated (2.15); the box goes where the grip takes it.
  const Pose box_next = grip.box(apply_increment(grip.hand_now, grip.hand_step));
  const PoseVector increment = companion_increment(box_now, grip.hand_now, grip.hand_step);
  const Pose predicted = apply_increment(box_now, increment);
  EXPECT_LT(test::translation_error(predicted, box_next), 1e-5f);
  EXPECT_LT(test::rotation_error(predicted, box_next), 1e-5f);
  // The box's own dX, lagging at zero, would leave it 8 cm x 3 degrees and 1 cm away.
  EXPECT_GT(test::translation_error(box_now, box_next), 0.01f);
}

TEST(CompanionMotion, AnObjectsOwnStepGivesItsVelocityBack) {
  const Grip grip;
  const PoseVector own = companion_increment(grip.hand_now, grip.hand_now, grip.hand_step);
  EXPECT_LT((own - grip.hand_step).norm(), 1e-6f);
}

TEST(CompanionMotion, ACompanionMustHaveMovedOrTurned) {
  CompanionOptions o;
  o.contact_distance = 0.02f;
  o.min_motion = 0.002f;
  o.min_turn_deg = 0.5f;
  EXPECT_FALSE(companion_moved(PoseVector::Zero(), o));
  EXPECT_FALSE(companion_moved((PoseVector() << 0.0015f, 0, 0, 0, 0, 0.005f).finished(), o));
  EXPECT_TRUE(companion_moved((PoseVector() << 0, 0.0025f, 0, 0, 0, 0).finished(), o));
  EXPECT_TRUE(companion_moved((PoseVector() << 0, 0, 0, 0, test::radians(0.6f), 0).finished(), o));
  // The reach of an increment: its translation plus its turn times the model's radius.
  const PoseVector turn_only = (PoseVector() << 0, 0, 0, 0, 0, 0.1f).finished();
  EXPECT_NEAR(increment_reach(turn_only, 0.05f), 0.005f, 1e-6f);
  EXPECT_NEAR(increment_reach((PoseVector() << 0.003f, 0.004f, 0, 0, 0, 0).finished(), 0.05f), 0.005f, 1e-6f);
}

TEST(CompanionMotion, OptionsOutOfRangeThrowNamingTheField) {
  CompanionOptions o;
  EXPECT_NO_THROW(o.validate());  // off by default
  o.contact_distance = -0.01f;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o.contact_distance = 0.2f;
  test::expect_invalid_argument([&] { o.validate(); }, "CompanionOptions.contact_distance");  // 0.2 m
  o.contact_distance = 0.02f;
  o.min_motion = 0.f;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o.min_motion = 0.002f;
  o.min_turn_deg = 200.f;
  EXPECT_THROW(o.validate(), std::invalid_argument);
}

}  // namespace
}  // namespace mfot
