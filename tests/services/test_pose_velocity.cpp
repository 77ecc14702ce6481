// PoseVelocityEstimator: velocities from poses and their frames' capture times, at any camera rate,
// across dropped frames, zero for first and stale poses.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>

#include "mfot/service/pose_velocity.hpp"

namespace mfot::service {
namespace {

// Constant motion: the object origin moves at kLinear (camera frame, m/s) and turns at kAngular
// (rotation vector per second, camera frame): R(t) = exp([kAngular t]x) R0.
const Eigen::Vector3d kLinear(0.30, -0.12, 0.05);
const Eigen::Vector3d kAngular(0.4, -1.1, 2.0);
const Eigen::Vector3d kStart(0.1, -0.2, 1.1);
const Eigen::Quaterniond kStartRotation(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, -1).normalized()));

Pose pose_at(double t) {
  Pose p;
  p.translation = (kStart + kLinear * t).cast<float>();
  const Eigen::Vector3d turn = kAngular * t;
  const Eigen::Quaterniond r = Eigen::Quaterniond(Eigen::AngleAxisd(turn.norm(), turn.normalized())) * kStartRotation;
  p.rotation = r.cast<float>();
  return p;
}

std::int64_t utime_of(int frame, double fps) { return 1'700'000'000'000'000 + std::llround(frame * 1e6 / fps); }

void expect_near(const Eigen::Vector3d& actual, const Eigen::Vector3d& expected, double tolerance) {
  EXPECT_NEAR((actual - expected).norm(), 0.0, tolerance)
      << "actual " << actual.transpose() << ", expected " << expected.transpose();
}

class AtFrameRate : public ::testing::TestWithParam<double> {};

TEST_P(AtFrameRate, ConstantMotionGivesItsVelocityFromTheSecondFrameOn) {
  const double fps = GetParam();
  PoseVelocityEstimator velocities;
  const ObjectVelocity first = velocities.update(1, pose_at(0), utime_of(0, fps), false);
  EXPECT_EQ(first.linear, Eigen::Vector3d::Zero());
  EXPECT_EQ(first.angular, Eigen::Vector3d::Zero());
  for (int frame = 1; frame < 10; ++frame) {
    const ObjectVelocity v = velocities.update(1, pose_at(frame / fps), utime_of(frame, fps), false);
    expect_near(v.linear, kLinear, 2e-4);
    expect_near(v.angular, kAngular, 2e-4);
  }
}

TEST_P(AtFrameRate, DroppedFramesGiveTheSameVelocity) {
  const double fps = GetParam();
  for (const int gap : {2, 3}) {
    PoseVelocityEstimator velocities;
    velocities.update(1, pose_at(0), utime_of(0, fps), false);
    const ObjectVelocity v = velocities.update(1, pose_at(gap / fps), utime_of(gap, fps), false);
    expect_near(v.linear, kLinear, 2e-4);
    expect_near(v.angular, kAngular, 2e-4);
  }
}

INSTANTIATE_TEST_SUITE_P(PoseVelocity, AtFrameRate, ::testing::Values(15.0, 30.0, 60.0));

TEST(PoseVelocity, AStalePoseHasZeroVelocityAndTheNextFreshOneTheMeanSinceTheLastFresh) {
  const double fps = 30;
  PoseVelocityEstimator velocities;
  velocities.update(1, pose_at(0), utime_of(0, fps), false);
  velocities.update(1, pose_at(1 / fps), utime_of(1, fps), false);
  const ObjectVelocity stale = velocities.update(1, pose_at(1 / fps), utime_of(2, fps), true);
  EXPECT_EQ(stale.linear, Eigen::Vector3d::Zero());
  EXPECT_EQ(stale.angular, Eigen::Vector3d::Zero());
  const ObjectVelocity fresh = velocities.update(1, pose_at(3 / fps), utime_of(3, fps), false);
  expect_near(fresh.linear, kLinear, 2e-4);
  expect_near(fresh.angular, kAngular, 2e-4);
}

TEST(PoseVelocity, ObjectsAreFollowedApartAndAForgottenOneStartsOver) {
  const double fps = 30;
  PoseVelocityEstimator velocities;
  Pose still = pose_at(0);
  velocities.update(1, pose_at(0), utime_of(0, fps), false);
  velocities.update(2, still, utime_of(0, fps), false);
  const ObjectVelocity moving = velocities.update(1, pose_at(1 / fps), utime_of(1, fps), false);
  const ObjectVelocity resting = velocities.update(2, still, utime_of(1, fps), false);
  expect_near(moving.linear, kLinear, 2e-4);
  expect_near(resting.linear, Eigen::Vector3d::Zero(), 1e-12);
  expect_near(resting.angular, Eigen::Vector3d::Zero(), 1e-12);
  velocities.forget(1);
  const ObjectVelocity again = velocities.update(1, pose_at(2 / fps), utime_of(2, fps), false);
  EXPECT_EQ(again.linear, Eigen::Vector3d::Zero());
  velocities.forget_unless([](std::int32_t id) { return id != 2; });
  EXPECT_EQ(velocities.update(2, pose_at(0), utime_of(3, fps), false).linear, Eigen::Vector3d::Zero());
}

TEST(PoseVelocity, ACaptureTimeNotAfterThePreviousStartsOver) {
  PoseVelocityEstimator velocities;
  velocities.update(1, pose_at(0), utime_of(10, 30), false);
  // A new frame sequence (a replay restarting): earlier capture time.
  const ObjectVelocity back = velocities.update(1, pose_at(0.5), utime_of(0, 30), false);
  EXPECT_EQ(back.linear, Eigen::Vector3d::Zero());
  EXPECT_EQ(velocities.update(1, pose_at(0.5), utime_of(0, 30), false).linear, Eigen::Vector3d::Zero());  // same time
  const ObjectVelocity next = velocities.update(1, pose_at(0.5 + 1 / 30.0), utime_of(1, 30), false);
  expect_near(next.linear, kLinear, 2e-4);
}

TEST(PoseVelocity, AHalfTurnAndMoreTakesTheShorterWay) {
  // 170 degrees about z in one frame at 30 frames/s, then on to 190 (= -170): the second step is
  // +20 degrees, not -340.
  PoseVelocityEstimator velocities;
  const auto about_z = [](double degrees) {
    Pose p;
    p.rotation =
        Eigen::Quaternionf(Eigen::AngleAxisf(static_cast<float>(degrees * M_PI / 180), Eigen::Vector3f::UnitZ()));
    return p;
  };
  velocities.update(1, about_z(0), utime_of(0, 30), false);
  expect_near(velocities.update(1, about_z(170), utime_of(1, 30), false).angular,
              Eigen::Vector3d(0, 0, 170 * M_PI / 180 * 30), 1e-3);
  expect_near(velocities.update(1, about_z(190), utime_of(2, 30), false).angular,
              Eigen::Vector3d(0, 0, 20 * M_PI / 180 * 30), 1e-3);
}

TEST(PoseVelocity, WorldFrameVelocitiesAreTheCameraOnesRotatedIntoTheWorld) {
  Pose world_from_camera;
  world_from_camera.rotation =
      Eigen::Quaternionf(Eigen::AngleAxisf(1.2f, Eigen::Vector3f(0.3f, -1, 0.5f).normalized()));
  world_from_camera.translation = Eigen::Vector3f(0.5f, 2.f, -1.f);  // a translation does not change velocities
  const Eigen::Matrix3d r = world_from_camera.rotation.cast<double>().toRotationMatrix();
  PoseVelocityEstimator velocities(world_from_camera);
  velocities.update(1, pose_at(0), utime_of(0, 30), false);
  const ObjectVelocity v = velocities.update(1, pose_at(1 / 30.0), utime_of(1, 30), false);
  expect_near(v.world_linear, r * kLinear, 2e-4);
  expect_near(v.world_angular, r * kAngular, 2e-4);
  // The same motion seen in the world frame directly: world poses differenced give the same.
  PoseVelocityEstimator in_world;
  const auto world_pose = [&](double t) {
    return Pose::from_isometry(world_from_camera.isometry() * pose_at(t).isometry());
  };
  in_world.update(1, world_pose(0), utime_of(0, 30), false);
  const ObjectVelocity w = in_world.update(1, world_pose(1 / 30.0), utime_of(1, 30), false);
  expect_near(w.linear, v.world_linear, 2e-4);
  expect_near(w.angular, v.world_angular, 2e-4);
}

}  // namespace
}  // namespace mfot::service
