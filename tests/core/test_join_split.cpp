#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

#include "mfot/join_split.hpp"
#include "synthetic_object.hpp"

namespace mfot {
namespace {

JoinSplitOptions join_options() {
  JoinSplitOptions o;
  o.join_frames = 5;
  return o;
}

// The first object moves 1 cm a frame along x and turns 1 degree about z; the second sits 8 cm beside it.
Pose mover_at(int frame) {
  return test::make_pose(Eigen::Vector3f(0.01f * static_cast<float>(frame), 0.f, 1.f), Eigen::Vector3f::UnitZ(),
                         test::radians(static_cast<float>(frame)));
}
Pose rigidly_beside(const Pose& first) {
  return Pose::from_isometry(first.isometry() * Eigen::Translation3f(0.08f, 0.f, 0.f));
}

const auto kTouch = [](std::int32_t, std::int32_t) { return true; };

TEST(RigidPartJoin, SiblingsThatMoveAsOneJoinAfterJoinFrames) {
  RigidPartJoin joiner(join_options());
  for (int frame = 0; frame < 5; ++frame) {
    const std::vector<JoinCandidate> objects{{3, 7, mover_at(frame), false},
                                             {5, 7, rigidly_beside(mover_at(frame)), false}};
    const auto joins = joiner.update(objects, kTouch);
    if (frame < 4) {
      EXPECT_TRUE(joins.empty()) << "frame " << frame;
    } else {
      ASSERT_EQ(joins.size(), 1u);
      EXPECT_EQ(joins[0], std::make_pair(3, 5));  // the younger joins the older
    }
  }
}

TEST(RigidPartJoin, NoJoinWithoutBirthMotionContactOrRigidity) {
  const auto run = [](auto second_at, std::uint64_t second_birth, auto touch, auto first_at) {
    RigidPartJoin joiner(join_options());
    std::size_t joins = 0;
    for (int frame = 0; frame < 12; ++frame) {
      const std::vector<JoinCandidate> objects{{1, 7, first_at(frame), false},
                                               {2, second_birth, second_at(frame), false}};
      joins += joiner.update(objects, touch).size();
    }
    return joins;
  };
  const auto beside = [](int frame) { return rigidly_beside(mover_at(frame)); };
  EXPECT_GT(run(beside, 7, kTouch, mover_at), 0u);  // the reference: siblings, moving, touching, rigid
  EXPECT_EQ(run(beside, 8, kTouch, mover_at), 0u);  // born from another cluster
  EXPECT_EQ(run(
                beside, 7, [](std::int32_t, std::int32_t) { return false; }, mover_at),
            0u);  // models apart
  const auto still = [](int) { return mover_at(0); };
  EXPECT_EQ(run([](int) { return rigidly_beside(mover_at(0)); }, 7, kTouch, still), 0u);     // never moved
  EXPECT_EQ(run([](int) { return rigidly_beside(mover_at(0)); }, 7, kTouch, mover_at), 0u);  // left behind
}

TEST(RigidPartJoin, ForgetDropsTheObjectsPairs) {
  RigidPartJoin joiner(join_options());
  const std::vector<JoinCandidate> objects{
      {1, 7, mover_at(0), false}, {2, 7, rigidly_beside(mover_at(0)), false}, {3, 7, mover_at(0), false}};
  joiner.update(objects, kTouch);
  EXPECT_EQ(joiner.watched_pairs(), 3u);
  joiner.forget(2);
  EXPECT_EQ(joiner.watched_pairs(), 1u);
}

TEST(JoinSplitOptions, RejectsOutOfRangeValues) {
  JoinSplitOptions o;
  o.join_translation = 0.f;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o = JoinSplitOptions{};
  o.split_min_gap = 0.f;
  o.split_min_departure = 0.01f;  // parts are followed within split_min_gap
  EXPECT_THROW(o.validate(), std::invalid_argument);
  EXPECT_THROW(RigidPartJoin{o}, std::invalid_argument);
  o = JoinSplitOptions{};
  o.overlap_share = 0.f;
  EXPECT_THROW(OverlapJoin{o}, std::invalid_argument);
}

JoinSplitOptions overlap_options() {
  JoinSplitOptions o;
  o.overlap_frames = 5;
  return o;
}

TEST(OverlapJoin, ObjectsSharingTheirSpaceForOverlapFramesAreOneAndTheLowerIdStays) {
  OverlapJoin joiner(overlap_options());
  const std::vector<OverlapCandidate> objects{{3, true}, {8, true}, {9, true}};
  const auto overlap = [](std::int32_t a, std::int32_t b) { return a == 3 && b == 8 ? 0.7f : 0.1f; };
  for (int frame = 0; frame < 5; ++frame) {
    const auto joins = joiner.update(objects, overlap);
    if (frame < 4) {
      EXPECT_TRUE(joins.empty()) << "frame " << frame;
    } else {
      ASSERT_EQ(joins.size(), 1u);
      EXPECT_EQ(joins[0], std::make_pair(3, 8));
    }
  }
}

TEST(OverlapJoin, AFrameApartHeldOrBelowTheShareStartsTheCountOver) {
  OverlapJoin joiner(overlap_options());
  const auto half = [](std::int32_t, std::int32_t) { return 0.5f; };
  const auto less = [](std::int32_t, std::int32_t) { return 0.49f; };
  const std::vector<OverlapCandidate> seen{{1, true}, {2, true}};
  const std::vector<OverlapCandidate> one_held{{1, true}, {2, false}};
  for (int frame = 0; frame < 4; ++frame) EXPECT_TRUE(joiner.update(seen, half).empty());
  EXPECT_TRUE(joiner.update(one_held, half).empty());  // a held estimate says nothing of where it is
  EXPECT_EQ(joiner.watched_pairs(), 0u);
  for (int frame = 0; frame < 4; ++frame) EXPECT_TRUE(joiner.update(seen, half).empty());
  EXPECT_TRUE(joiner.update(seen, less).empty());
  for (int frame = 0; frame < 4; ++frame) EXPECT_TRUE(joiner.update(seen, half).empty());
  EXPECT_EQ(joiner.update(seen, half).size(), 1u);
  joiner.forget(2);
  EXPECT_EQ(joiner.watched_pairs(), 0u);
}

JoinSplitOptions split_options() {
  JoinSplitOptions o;
  o.split_frames = 3;
  o.split_min_gap = 0.03f;
  o.split_min_departure = 0.015f;
  return o;
}

// An object seen as two clusters 10 cm apart: `kept` (60 points) moves with the object, 1 cm a frame along x;
// `other` (40 points) moves with it too, or stays where it was (a box a hand let go of).
struct TwoParts {
  bool other_stays = true;
  std::vector<Eigen::Vector3f> scene;
  std::map<std::int32_t, std::vector<int>> clusters;
  Pose pose;
  void at(int frame) {
    const float shift = 0.01f * static_cast<float>(frame);
    pose = test::make_pose(Eigen::Vector3f(shift, 0.f, 1.f), Eigen::Vector3f::UnitZ(), 0.f);
    scene.clear();
    clusters.clear();
    for (int k = 0; k < 60; ++k) {
      clusters[0].push_back(static_cast<int>(scene.size()));
      scene.emplace_back(shift + 0.001f * static_cast<float>(k % 10), 0.001f * static_cast<float>(k / 10), 1.f);
    }
    for (int k = 0; k < 40; ++k) {
      clusters[1].push_back(static_cast<int>(scene.size()));
      scene.emplace_back((other_stays ? 0.f : shift) + 0.1f + 0.001f * static_cast<float>(k % 10),
                         0.001f * static_cast<float>(k / 10), 1.f);
    }
  }
};

const auto kNothingHidden = [] { return 0.f; };

TEST(PartSplit, APartLeftBehindSplitsOffAfterSplitFrames) {
  PartSplit splitter(split_options(), 10);
  TwoParts object;
  SplitWatch watch;
  std::vector<int> own;
  std::vector<std::vector<int>> leaving;
  for (int frame = 0; frame < 3; ++frame) {
    object.at(frame);
    const bool split =
        splitter.update(object.pose, false, object.clusters, object.scene, kNothingHidden, watch, own, leaving);
    if (frame < 2) {
      EXPECT_FALSE(split) << "frame " << frame;
      EXPECT_EQ(watch.streak, frame + 1);
    } else {
      ASSERT_TRUE(split);
      EXPECT_EQ(own, object.clusters[0]);  // the larger part stays the object's
      ASSERT_EQ(leaving.size(), 1u);
      EXPECT_EQ(leaving[0], object.clusters[1]);
      EXPECT_EQ(watch.streak, 0);  // starts over
      EXPECT_TRUE(watch.parts.empty());
    }
  }
}

TEST(PartSplit, PartsThatMoveTogetherStayOneObject) {
  PartSplit splitter(split_options(), 10);
  TwoParts object;
  object.other_stays = false;
  SplitWatch watch;
  std::vector<int> own;
  std::vector<std::vector<int>> leaving;
  for (int frame = 0; frame < 10; ++frame) {
    object.at(frame);
    EXPECT_FALSE(
        splitter.update(object.pose, false, object.clusters, object.scene, kNothingHidden, watch, own, leaving));
  }
  EXPECT_EQ(watch.streak, 10);  // in parts all along, but one body
  EXPECT_EQ(watch.parts.size(), 2u);
}

TEST(PartSplit, NotApartWhenHiddenStaleOrWithinTheGap) {
  TwoParts object;
  const auto streak_after = [&](JoinSplitOptions o, bool stale, float hidden) {
    PartSplit splitter(o, 10);
    SplitWatch watch;
    std::vector<int> own;
    std::vector<std::vector<int>> leaving;
    for (int frame = 0; frame < 2; ++frame) {
      object.at(frame);
      splitter.update(
          object.pose, stale, object.clusters, object.scene, [hidden] { return hidden; }, watch, own, leaving);
    }
    return watch.streak;
  };
  EXPECT_EQ(streak_after(split_options(), false, 0.f), 2);
  EXPECT_EQ(streak_after(split_options(), true, 0.f), 0);    // no estimate
  EXPECT_EQ(streak_after(split_options(), false, 0.5f), 0);  // a hand in front cuts it in two
  JoinSplitOptions wide = split_options();
  wide.split_min_gap = 0.2f;  // the parts lie 9.1 cm apart
  EXPECT_EQ(streak_after(wide, false, 0.f), 0);
}

}  // namespace
}  // namespace mfot
