#include "mfot/carry_monitor.hpp"
#include "synthetic_object.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <stdexcept>
#include <vector>

namespace mfot {
namespace {

CarryOptions carry_options() {
  CarryOptions o;
  o.frames = 5;
  return o;
}

// A hand (id 2) that moves 1 cm and turns 3 degrees a frame about an oblique axis, and a box (id 1)
// gripped 8 cm from its origin: the box's pose is the hand's times a fixed relative pose.
struct Carrying {
  Eigen::Isometry3f relative = test::make_pose(Eigen::Vector3f(0.08f, -0.02f, 0.01f), Eigen::Vector3f::UnitZ(), 0.4f).isometry();
  Pose hand_at(int frame) const {
    return test::make_pose(Eigen::Vector3f(0.01f * static_cast<float>(frame), 0.f, 1.f), Eigen::Vector3f(1.f, 0.3f, 0.2f),
                           test::radians(3.f * static_cast<float>(frame)));
  }
  Pose box_at(int frame) const { return Pose::from_isometry(hand_at(frame).isometry() * relative); }
};

const CarryMonitor::TouchTest kAlwaysTouch = [](std::int32_t, std::int32_t) { return true; };

TEST(CarryMonitor, AHiddenObjectFollowsTheObjectItMovedWith) {
  const Carrying scene;
  CarryMonitor monitor(carry_options());
  for (int frame = 0; frame < 6; ++frame) {
    const std::vector<CarryMonitor::Object> seen{{1, scene.box_at(frame), false}, {2, scene.hand_at(frame), false}};
    EXPECT_TRUE(monitor.update(seen, kAlwaysTouch).empty()) << "frame " << frame;
  }
  // Hidden from frame 6 on: its own estimate waits at frame 5's pose, the hand goes on.
  for (int frame = 6; frame < 16; ++frame) {
    const std::vector<CarryMonitor::Object> objects{{1, scene.box_at(5), true}, {2, scene.hand_at(frame), false}};
    const auto& carried = monitor.update(objects, kAlwaysTouch);
    ASSERT_EQ(carried.size(), 1u) << "frame " << frame;
    EXPECT_EQ(carried[0].id, 1);
    EXPECT_EQ(carried[0].carrier, 2);
    EXPECT_LT(test::translation_error(carried[0].pose, scene.box_at(frame)), 1e-5f) << "frame " << frame;
    EXPECT_LT(test::degrees(test::rotation_error(carried[0].pose, scene.box_at(frame))), 0.01f) << "frame " << frame;
  }
  // Seen again: nothing carried.
  const std::vector<CarryMonitor::Object> seen{{1, scene.box_at(16), false}, {2, scene.hand_at(16), false}};
  EXPECT_TRUE(monitor.update(seen, kAlwaysTouch).empty());
}

// The two estimates of a long grip drift apart (the box's lags the hand's turn): 20 degrees over 40 frames
// breaks no 20-frame window of 15 degrees, so the box is carried when it is hidden (a watch measured from
// its start would have broken at frame 31 and been too short by then); 25 degrees in the last 5 frames (a
// hand turning over a box it does not hold) breaks the watch, and nothing is carried.
TEST(CarryMonitor, ASlowDriftOverALongGripKeepsTheWatchAFastOneBreaksIt) {
  const Carrying scene;
  CarryOptions options = carry_options();
  options.frames = 20;
  for (const bool slow : {true, false}) {
    SCOPED_TRACE(slow ? "0.5 deg a frame" : "5 deg a frame at the end");
    const auto box_at = [&](int frame) {
      const float deg = slow ? 0.5f * static_cast<float>(frame) : 5.f * static_cast<float>(std::max(0, frame - 34));
      return Pose::from_isometry(scene.hand_at(frame).isometry() * scene.relative *
                                 Eigen::Isometry3f(Eigen::AngleAxisf(test::radians(deg), Eigen::Vector3f::UnitZ())));
    };
    CarryMonitor monitor(options);
    for (int frame = 0; frame < 40; ++frame) {
      monitor.update(std::vector<CarryMonitor::Object>{{1, box_at(frame), false}, {2, scene.hand_at(frame), false}},
                     kAlwaysTouch);
    }
    const auto& carried = monitor.update(
        std::vector<CarryMonitor::Object>{{1, box_at(39), true}, {2, scene.hand_at(40), false}}, kAlwaysTouch);
    ASSERT_EQ(carried.size(), slow ? 1u : 0u);
    if (!slow) continue;
    EXPECT_LT(test::translation_error(carried[0].pose, Pose::from_isometry(scene.hand_at(40).isometry() *
                                                                                     scene.hand_at(39).isometry().inverse() *
                                                                                     box_at(39).isometry())),
                        1e-4f);
  }
}

TEST(CarryMonitor, StillApartShortOrForgottenCompanionsCarryNothing) {
  const Carrying scene;
  const auto hide_after = [&](CarryMonitor& monitor, const auto& hand_at, const auto& box_at, int frames,
                              const CarryMonitor::TouchTest& touch) {
    for (int frame = 0; frame < frames; ++frame) {
      const std::vector<CarryMonitor::Object> seen{{1, box_at(frame), false}, {2, hand_at(frame), false}};
      monitor.update(seen, touch);
    }
    const std::vector<CarryMonitor::Object> hidden{{1, box_at(frames - 1), true}, {2, hand_at(frames), false}};
    return monitor.update(hidden, touch).size();
  };
  const auto hand = [&](int f) { return scene.hand_at(f); };
  const auto box = [&](int f) { return scene.box_at(f); };
  {  // the same motion together: carried (the reference case of the blocks below)
    CarryMonitor monitor(carry_options());
    EXPECT_EQ(hide_after(monitor, hand, box, 8, kAlwaysTouch), 1u);
  }
  {  // a hand resting beside the box: it never moved
    CarryMonitor monitor(carry_options());
    EXPECT_EQ(hide_after(monitor, [&](int) { return scene.hand_at(0); }, [&](int) { return scene.box_at(0); }, 20,
                         kAlwaysTouch),
              0u);
  }
  {  // a hand passing over a still box: their relative pose drifts beyond the tolerance
    CarryMonitor monitor(carry_options());
    EXPECT_EQ(hide_after(monitor, hand, [&](int) { return scene.box_at(0); }, 20, kAlwaysTouch), 0u);
  }
  {  // moving together but never touching
    CarryMonitor monitor(carry_options());
    EXPECT_EQ(hide_after(monitor, hand, box, 20, [](std::int32_t, std::int32_t) { return false; }), 0u);
  }
  {  // together for fewer frames than options.frames
    CarryMonitor monitor(carry_options());
    EXPECT_EQ(hide_after(monitor, hand, box, 4, kAlwaysTouch), 0u);
  }
  {  // the hand retired (forgotten) and a new object 2 takes its place
    CarryMonitor monitor(carry_options());
    for (int frame = 0; frame < 8; ++frame) {
      const std::vector<CarryMonitor::Object> seen{{1, scene.box_at(frame), false}, {2, scene.hand_at(frame), false}};
      monitor.update(seen, kAlwaysTouch);
    }
    monitor.forget(2);
    const std::vector<CarryMonitor::Object> hidden{{1, scene.box_at(7), true}, {2, scene.hand_at(8), false}};
    EXPECT_TRUE(monitor.update(hidden, kAlwaysTouch).empty());
  }
  {  // off
    CarryOptions off = carry_options();
    off.frames = 0;
    CarryMonitor monitor(off);
    EXPECT_EQ(hide_after(monitor, hand, box, 8, kAlwaysTouch), 0u);
  }
}

TEST(CarryMonitor, TheLongestCompanionCarries) {
  const Carrying scene;
  CarryMonitor monitor(carry_options());
  const Eigen::Isometry3f other_offset = test::make_pose(Eigen::Vector3f(0.f, 0.1f, 0.f), Eigen::Vector3f::UnitX(), 0.f).isometry();
  // Object 3 moves with the box too, but joins it five frames after the hand.
  for (int frame = 0; frame < 15; ++frame) {
    const Pose other = frame < 5 ? scene.box_at(0) : Pose::from_isometry(scene.box_at(frame).isometry() * other_offset);
    const std::vector<CarryMonitor::Object> seen{
        {1, scene.box_at(frame), false}, {2, scene.hand_at(frame), false}, {3, other, false}};
    monitor.update(seen, kAlwaysTouch);
  }
  const std::vector<CarryMonitor::Object> hidden{{1, scene.box_at(14), true},
                                                  {2, scene.hand_at(15), false},
                                                  {3, Pose::from_isometry(scene.box_at(15).isometry() * other_offset), false}};
  const auto& carried = monitor.update(hidden, kAlwaysTouch);
  ASSERT_EQ(carried.size(), 1u);
  EXPECT_EQ(carried[0].carrier, 2);
}

TEST(CarryMonitor, InvalidOptionsThrow) {
  CarryOptions o;
  o.frames = -1;
  EXPECT_THROW(CarryMonitor{o}, std::invalid_argument);
  o = CarryOptions{};
  o.translation = 0.f;
  EXPECT_THROW(CarryMonitor{o}, std::invalid_argument);
  o = CarryOptions{};
  o.rotation_deg = 120.f;
  EXPECT_THROW(CarryMonitor{o}, std::invalid_argument);
  o = CarryOptions{};
  o.min_motion = -0.1f;
  EXPECT_THROW(CarryMonitor{o}, std::invalid_argument);
  o = CarryOptions{};
  o.contact_distance = 0.5f;
  EXPECT_THROW(CarryMonitor{o}, std::invalid_argument);
  EXPECT_NO_THROW(CarryMonitor{CarryOptions{}});
}

}  // namespace
}  // namespace mfot
