#include <gtest/gtest.h>

#include <map>
#include <memory>
#include <set>
#include <tuple>

#include "expect_invalid_argument.hpp"
#include "mfot/object_manager.hpp"
#include "synthetic_object.hpp"

namespace mfot {
namespace {

// A solid block of points on a 5 mm lattice, coloured by its position so that models have texture.
void add_block(ColoredCloud& cloud, std::vector<std::int32_t>& cluster, std::int32_t cluster_id,
               const Eigen::Vector3f& min, const Eigen::Vector3i& cells) {
  for (int x = 0; x < cells.x(); ++x) {
    for (int y = 0; y < cells.y(); ++y) {
      for (int z = 0; z < cells.z(); ++z) {
        cloud.push_back(
            min + 0.005f * Eigen::Vector3f(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)),
            {static_cast<std::uint8_t>(40 * x % 256), static_cast<std::uint8_t>(200 - 10 * y), 90});
        cluster.push_back(cluster_id);
      }
    }
  }
}

struct TwoBlocks {
  ColoredCloud cloud;
  std::vector<std::int32_t> cluster;
  TwoBlocks() {
    add_block(cloud, cluster, 0, {-0.2f, 0.f, 1.f}, {12, 12, 6});
    add_block(cloud, cluster, 1, {0.1f, 0.f, 1.f}, {10, 14, 6});
  }
};

std::map<std::int32_t, ObjectEstimate> unchanged(const ObjectManager& manager) {
  std::map<std::int32_t, ObjectEstimate> estimates;
  for (const auto& [id, object] : manager.objects()) estimates[id] = {object.pose, 1.f};
  return estimates;
}

TEST(ObjectManager, FirstFrameMakesOneObjectPerClusterAndLabelsIt) {
  TwoBlocks scene;
  ObjectManager manager;
  const auto& frame = manager.process(scene.cloud, scene.cluster, {});
  ASSERT_EQ(frame.created, (std::vector<std::int32_t>{1, 2}));
  ASSERT_EQ(manager.objects().size(), 2u);
  for (std::size_t i = 0; i < scene.cloud.size(); ++i) EXPECT_EQ(frame.labels[i], scene.cluster[i] + 1);
  // The model sits at the cluster's centroid, in an axis-aligned frame: moved back by the pose it
  // reproduces the cluster.
  const ManagedObject& first = manager.objects().at(1);
  EXPECT_EQ(first.model.cloud.size(), 12u * 12u * 6u);
  EXPECT_EQ(first.model.features.size(), first.model.cloud.size());
  EXPECT_TRUE((first.pose.isometry() * first.model.cloud.positions[0]).isApprox(scene.cloud.positions[0], 1e-5f));
}

TEST(ObjectManager, ClaimedPointsAreTheOtherObjectsModelPointsInsideAnObjectsGrownBox) {
  TwoBlocks scene;
  // A thin third block 1.5 cm right of the first (x from -0.13 to -0.115 m).
  add_block(scene.cloud, scene.cluster, 2, {-0.13f, 0.f, 1.f}, {4, 12, 6});
  ObjectManager manager;
  manager.process(scene.cloud, scene.cluster, {});
  ASSERT_EQ(manager.objects().size(), 3u);
  std::vector<Eigen::Vector3f> claimed;
  // The first block's box ends at x = -0.145: grown by 2.2 cm it takes the third block's two
  // nearest columns (x = -0.13 and -0.125), at their poses, in the camera frame; the far block none.
  manager.claimed_points(1, 0.022f, claimed);
  ASSERT_EQ(claimed.size(), 2u * 12u * 6u);
  for (const Eigen::Vector3f& p : claimed) {
    EXPECT_LT(p.x(), -0.1225f);
    EXPECT_GT(p.x(), -0.1325f);
    EXPECT_GE(p.z(), 1.f - 1e-5f);
  }
  manager.claimed_points(1, 0.f, claimed);
  EXPECT_TRUE(claimed.empty());
  manager.claimed_points(3, 0.022f, claimed);  // the first block's two columns nearest the third
  EXPECT_EQ(claimed.size(), 2u * 12u * 6u);
  manager.claimed_points(42, 1.f, claimed);
  EXPECT_TRUE(claimed.empty());
  manager.claimed_points(2, 1.f, claimed);  // everything else, within a metre
  EXPECT_EQ(claimed.size(), scene.cloud.size() - manager.objects().at(2).model.cloud.size());
}

// Splits a cluster at x = 0 (a stand-in for the convexity discovery).
class SplitAtXZero final : public ObjectDiscovery {
 public:
  int calls = 0;
  int split(std::span<const Eigen::Vector3f> positions, std::span<const Rgb8>, std::vector<int>& part) override {
    ++calls;
    part.assign(positions.size(), 0);
    int first = -1;
    for (std::size_t i = 0; i < positions.size(); ++i) {
      const int side = positions[i].x() < 0.f ? 0 : 1;
      if (first < 0) first = side;
      part[i] = side == first ? 0 : 1;
    }
    return std::set<int>(part.begin(), part.end()).size();
  }
};

TEST(ObjectManager, ADiscoverySplitsABornClusterIntoObjects) {
  ColoredCloud cloud;
  std::vector<std::int32_t> cluster;
  add_block(cloud, cluster, 0, {-0.0275f, 0.f, 1.f}, {12, 12, 6});  // one cluster across x = 0
  auto discovery = std::make_unique<SplitAtXZero>();
  SplitAtXZero* calls = discovery.get();
  ObjectManager manager({}, std::move(discovery));
  const auto& frame = manager.process(cloud, cluster, {});
  ASSERT_EQ(frame.created, (std::vector<std::int32_t>{1, 2}));
  for (std::size_t i = 0; i < cloud.size(); ++i) EXPECT_EQ(frame.labels[i], cloud.positions[i].x() < 0.f ? 1 : 2);
  EXPECT_EQ(calls->calls, 1);
  // Tracked objects that explain the scene are never split again: discovery runs at birth only.
  manager.process(cloud, cluster, unchanged(manager));
  EXPECT_EQ(calls->calls, 1);
  EXPECT_EQ(manager.objects().size(), 2u);
}

TEST(ObjectManager, DiscoveredPartsBelowTheObjectMinimumAreNoObjects) {
  ColoredCloud cloud;
  std::vector<std::int32_t> cluster;
  add_block(cloud, cluster, 0, {-0.0525f, 0.f, 1.f}, {12, 2, 2});  // 11 x 4 points left of 0, 1 x 4 right
  ObjectManagerOptions options;
  options.min_object_points = 20;
  ObjectManager manager(options, std::make_unique<SplitAtXZero>());
  const auto& frame = manager.process(cloud, cluster, {});
  EXPECT_EQ(frame.created, (std::vector<std::int32_t>{1}));
}

TEST(ObjectManager, ARetiredObjectsLastPointsPassNoLabelOn) {
  TwoBlocks scene;
  ObjectManagerOptions options;
  options.support.max_frames = 3;
  options.growth_frames = 0;
  ObjectManager manager(options);
  manager.process(scene.cloud, scene.cluster, {});
  // Ten points of the second block stay (too few to support it), in one cluster with points no
  // model explains (1.15 cm from its model, within the propagation radius of those ten).
  ColoredCloud later;
  std::vector<std::int32_t> cluster;
  add_block(later, cluster, 0, {-0.2f, 0.f, 1.f}, {12, 12, 6});
  add_block(later, cluster, 1, {0.1f, 0.f, 1.f}, {1, 2, 5});
  const std::size_t first_new = later.size();
  add_block(later, cluster, 1, {0.1f, -0.0265f, 1.f}, {4, 4, 6});
  std::vector<std::int32_t> retired;
  for (int t = 0; t < 3; ++t) {
    const ObjectManagerFrame* frame = nullptr;
    ASSERT_NO_THROW(frame = &manager.process(later, cluster, unchanged(manager))) << "frame " << t;
    retired.insert(retired.end(), frame->retired.begin(), frame->retired.end());
    if (t < 2) {
      EXPECT_EQ(frame->labels[first_new], 2) << "propagated from the second block's points";
    } else {
      // Retired this frame: its points and what they reached are unexplained.
      for (std::size_t i = 12 * 12 * 6; i < later.size(); ++i) EXPECT_NE(frame->labels[i], 2) << i;
    }
  }
  EXPECT_EQ(retired, (std::vector<std::int32_t>{2}));
}

TEST(ObjectManager, KeepsSegmentingAndMarksMissingEstimatesStale) {
  TwoBlocks scene;
  ObjectManager manager;
  manager.process(scene.cloud, scene.cluster, {});
  auto estimates = unchanged(manager);
  estimates.erase(2);
  const auto& frame = manager.process(scene.cloud, scene.cluster, estimates);
  EXPECT_TRUE(frame.created.empty());
  EXPECT_FALSE(manager.objects().at(1).stale);
  EXPECT_TRUE(manager.objects().at(2).stale);
  for (std::size_t i = 0; i < scene.cloud.size(); ++i) EXPECT_EQ(frame.labels[i], scene.cluster[i] + 1);
}

TEST(ObjectManager, RetiresAnObjectThatLostItsSupport) {
  TwoBlocks scene;
  ObjectManagerOptions options;
  options.support.max_frames = 3;
  ObjectManager manager(options);
  manager.process(scene.cloud, scene.cluster, {});
  // The second block leaves the view.
  ColoredCloud remaining;
  std::vector<std::int32_t> cluster;
  add_block(remaining, cluster, 0, {-0.2f, 0.f, 1.f}, {12, 12, 6});
  std::vector<std::int32_t> retired;
  for (int t = 0; t < 3; ++t) {
    const auto& frame = manager.process(remaining, cluster, unchanged(manager));
    retired.insert(retired.end(), frame.retired.begin(), frame.retired.end());
  }
  EXPECT_EQ(retired, (std::vector<std::int32_t>{2}));
  EXPECT_EQ(manager.objects().count(2), 0u);
  EXPECT_EQ(manager.objects().count(1), 1u);
}

TEST(ObjectManager, KeepsAnObjectHiddenBehindAnotherSurface) {
  TwoBlocks scene;
  ObjectManagerOptions options;
  options.support.max_frames = 3;
  options.hidden_occluded_share = 0.6f;
  ObjectManager manager(options);
  manager.process(scene.cloud, scene.cluster, {});
  // A plate 20 cm nearer the camera hides the second block (x in [0.1, 0.165] m at 1 m) from view.
  ColoredCloud hidden;
  std::vector<std::int32_t> cluster;
  add_block(hidden, cluster, 0, {-0.2f, 0.f, 1.f}, {12, 12, 6});
  add_block(hidden, cluster, 1, {0.06f, -0.04f, 0.8f}, {24, 30, 1});
  for (int t = 0; t < 6; ++t) {
    const auto& frame = manager.process(hidden, cluster, unchanged(manager));
    EXPECT_TRUE(frame.retired.empty());
  }
  EXPECT_EQ(manager.objects().count(2), 1u);
  // The thesis's rule (every frame without support counts) retires it.
  options.hidden_occluded_share = 0.f;
  ObjectManager thesis(options);
  thesis.process(scene.cloud, scene.cluster, {});
  std::vector<std::int32_t> retired;
  for (int t = 0; t < 3; ++t) {
    const auto& frame = thesis.process(hidden, cluster, unchanged(thesis));
    retired.insert(retired.end(), frame.retired.begin(), frame.retired.end());
  }
  EXPECT_EQ(retired, (std::vector<std::int32_t>{2}));
}

TEST(ObjectManager, AnObjectComingBackTakesItsIdBackAndADifferentOneDoesNot) {
  TwoBlocks scene;
  ObjectManagerOptions options;
  options.support.max_frames = 2;
  options.new_objects.confirm_frames = 1;
  ObjectManager manager(options);
  manager.process(scene.cloud, scene.cluster, {});
  const std::int32_t version = manager.objects().at(2).version;
  ColoredCloud remaining;
  std::vector<std::int32_t> cluster;
  add_block(remaining, cluster, 0, {-0.2f, 0.f, 1.f}, {12, 12, 6});
  for (int t = 0; t < 2; ++t) manager.process(remaining, cluster, unchanged(manager));
  ASSERT_EQ(manager.objects().count(2), 0u);

  // The same block reaches in elsewhere: id 2 again, with a newer model version.
  ColoredCloud back = remaining;
  std::vector<std::int32_t> back_cluster = cluster;
  add_block(back, back_cluster, 1, {0.15f, 0.05f, 1.f}, {10, 14, 6});
  const auto& returned = manager.process(back, back_cluster, unchanged(manager));
  EXPECT_EQ(returned.created, (std::vector<std::int32_t>{2}));
  EXPECT_GT(manager.objects().at(2).version, version);

  // A block of other colours is a new object.
  ColoredCloud other = back;
  std::vector<std::int32_t> other_cluster = back_cluster;
  const std::size_t first_new = other.size();
  add_block(other, other_cluster, 2, {0.f, 0.2f, 1.f}, {8, 8, 6});
  for (std::size_t i = first_new; i < other.size(); ++i) other.colors[i] = {20, 30, 220};
  const auto& fresh = manager.process(other, other_cluster, unchanged(manager));
  EXPECT_EQ(fresh.created, (std::vector<std::int32_t>{3}));

  // Re-identification off: the returning block gets a new id.
  options.reidentify_frames = 0;
  ObjectManager forgetful(options);
  forgetful.process(scene.cloud, scene.cluster, {});
  for (int t = 0; t < 2; ++t) forgetful.process(remaining, cluster, unchanged(forgetful));
  EXPECT_EQ(forgetful.process(back, back_cluster, unchanged(forgetful)).created, (std::vector<std::int32_t>{3}));
}

// The first block slides 10 cm while its tracker holds it where it was (a hand in front of it), or while it is lost
// (no estimate moves it: it lacks support, not yet retired): its points persist elsewhere, unexplained, and become a
// new object. That object takes the unseen object's id and model at its birth: id 1 is retired and created in that
// frame, its model put on the moved points, and no id 3 is born. Painted another colour, the moved block is another
// object (id 3) and object 1 stays as it was; with reidentify_unseen_radius_ratio 0 (the thesis) the slid block is
// id 3 too.
TEST(ObjectManager, AnUnseenObjectFoundElsewhereKeepsItsIdAndADifferentOneDoesNot) {
  const Eigen::Vector3f slide(0.f, 0.1f, 0.f);
  struct Run {
    std::vector<std::int32_t> created, retired;
    std::set<std::int32_t> ids;
    Eigen::Vector3f first_centroid = Eigen::Vector3f::Zero();  // object 1's model centroid at its pose, camera frame
  };
  const auto run = [&](bool held, bool repainted, float ratio) {
    TwoBlocks scene;
    ObjectManagerOptions options;
    options.new_objects.confirm_frames = 3;
    options.reidentify_unseen_radius_ratio = ratio;
    ObjectManager manager(options);
    manager.process(scene.cloud, scene.cluster, {});
    ColoredCloud slid = scene.cloud;
    Eigen::Vector3f moved_centroid = Eigen::Vector3f::Zero();
    int moved = 0;
    for (std::size_t i = 0; i < slid.size(); ++i) {
      if (scene.cluster[i] != 0) continue;
      slid.positions[i] += slide;
      if (repainted) slid.colors[i] = {20, 30, 220};
      moved_centroid += slid.positions[i];
      ++moved;
    }
    moved_centroid /= static_cast<float>(moved);
    Run out;
    for (int t = 0; t < 4; ++t) {
      std::map<std::int32_t, ObjectEstimate> estimates = unchanged(manager);
      if (held && estimates.contains(1)) estimates.at(1).held = true;
      if (!held && t < 3) estimates.erase(1);  // lost: its estimate stays where it was
      const ObjectManagerFrame& frame = manager.process(slid, scene.cluster, estimates);
      out.created.insert(out.created.end(), frame.created.begin(), frame.created.end());
      out.retired.insert(out.retired.end(), frame.retired.begin(), frame.retired.end());
    }
    for (const auto& [id, object] : manager.objects()) out.ids.insert(id);
    if (manager.objects().contains(1)) {
      const ManagedObject& first = manager.objects().at(1);
      for (const Eigen::Vector3f& p : first.model.cloud.positions) out.first_centroid += first.pose.isometry() * p;
      out.first_centroid /= static_cast<float>(first.model.cloud.size());
      out.first_centroid -= moved_centroid;  // 0 where the moved points are
    }
    return out;
  };
  using Ids = std::vector<std::int32_t>;
  for (const bool held : {true, false}) {
    const Run found = run(held, false, 2.f);
    EXPECT_EQ(found.created, Ids{1}) << "held " << held;
    EXPECT_EQ(found.retired, Ids{1}) << "held " << held;
    EXPECT_EQ(found.ids, (std::set<std::int32_t>{1, 2})) << "held " << held;
    EXPECT_LT(found.first_centroid.norm(), 0.01f) << "held " << held;  // its model where the block is now

    const Run other = run(held, true, 2.f);
    EXPECT_EQ(other.created, Ids{3}) << "held " << held;
    EXPECT_TRUE(other.retired.empty()) << "held " << held;
    EXPECT_EQ(other.ids, (std::set<std::int32_t>{1, 2, 3})) << "held " << held;
    EXPECT_NEAR(other.first_centroid.norm(), slide.norm(), 0.001f) << "held " << held;  // where it was

    EXPECT_EQ(run(held, false, 0.f).created, Ids{3}) << "held " << held;
  }
  ObjectManagerOptions bad;
  for (const float ratio : {-1.f, 0.5f, 11.f}) {
    bad.reidentify_unseen_radius_ratio = ratio;
    EXPECT_THROW(ObjectManager{bad}, std::invalid_argument) << ratio;
  }
}

TEST(ObjectManager, AReidentifiedObjectKeepsItsFrameAndModel) {
  // The textured test box is seen, lost for two frames, and seen again moved and turned 60 degrees
  // about the line of sight (the same faces show: its colours match). Its remembered model is
  // registered on the new points: its frame moved with it.
  const Eigen::Vector3f size(0.10f, 0.15f, 0.08f);
  const ColoredCloud box = test::make_test_object(0.f, 0.008f, true);
  const Pose before = test::make_pose(Eigen::Vector3f(0.f, 0.f, 0.9f), Eigen::Vector3f(1.f, 0.5f, 0.f), 0.6f);
  Pose after = test::make_pose(Eigen::Vector3f(0.08f, -0.03f, 0.95f), Eigen::Vector3f::UnitZ(), 1.05f);
  after.rotation = (after.rotation * before.rotation).normalized();
  auto frame = [&](const Pose& pose) {
    const ColoredCloud seen = test::seen_from_origin(box, size, pose);
    return std::make_pair(seen, std::vector<std::int32_t>(seen.size(), 0));
  };
  auto run = [&] {
    ObjectManagerOptions options;
    options.support.max_frames = 2;
    options.new_objects.confirm_frames = 1;
    auto manager = std::make_unique<ObjectManager>(options);
    const auto [first, first_cluster] = frame(before);
    manager->process(first, first_cluster, {});
    for (int t = 0; t < 2; ++t) manager->process(ColoredCloud{}, {}, unchanged(*manager));
    EXPECT_TRUE(manager->objects().empty());
    return manager;
  };
  const auto [back, back_cluster] = frame(after);

  const auto manager = run();
  ObjectManager reference;  // what the object's frame was: made from the first view alone
  const auto [first, first_cluster] = frame(before);
  reference.process(first, first_cluster, {});
  const Pose born = reference.objects().at(1).pose;
  const ObjectManagerFrame& returned = manager->process(back, back_cluster, unchanged(*manager));
  EXPECT_EQ(returned.created, (std::vector<std::int32_t>{1}));
  EXPECT_EQ(returned.registered, (std::vector<std::int32_t>{1}));
  // The frame moved with the box: born pose carried by the box's motion.
  const Pose expected = Pose::from_isometry(after.isometry() * before.isometry().inverse() * born.isometry());
  const ManagedObject& object = manager->objects().at(1);
  EXPECT_LT(test::degrees(test::rotation_error(object.pose, expected)), 3.f);
  EXPECT_LT(test::translation_error(object.pose, expected), 0.006f);
  EXPECT_GE(object.model.cloud.size(), reference.objects().at(1).model.cloud.size());  // remembered model kept
}

TEST(ObjectManager, AGrownObjectReachingInAgainIsKnownByItsFirstView) {
  // A red hand reaches in, then mostly its blue arm is seen: the last model is mostly blue. When it
  // leaves and the red hand reaches in again, its first view still matches.
  auto paint = [](ColoredCloud& cloud, std::size_t from, Rgb8 color) {
    for (std::size_t i = from; i < cloud.size(); ++i) cloud.colors[i] = color;
  };
  ColoredCloud hand;
  std::vector<std::int32_t> hand_cluster;
  add_block(hand, hand_cluster, 0, {0.f, 0.f, 1.f}, {10, 10, 1});
  paint(hand, 0, {200, 30, 35});
  ColoredCloud arm = hand;
  std::vector<std::int32_t> arm_cluster = hand_cluster;
  add_block(arm, arm_cluster, 0, {0.05f, 0.f, 1.f}, {60, 10, 1});
  paint(arm, hand.size(), {35, 70, 200});
  ObjectManagerOptions options;
  options.support.max_frames = 2;
  options.new_objects.confirm_frames = 1;
  ObjectManager manager(options);
  manager.process(hand, hand_cluster, {});
  manager.process(arm, arm_cluster, unchanged(manager));
  ASSERT_EQ(manager.objects().size(), 1u);
  ASSERT_GT(manager.objects().at(1).model.cloud.size(), hand.size() * 3);
  for (int t = 0; t < 2; ++t) manager.process(ColoredCloud{}, {}, unchanged(manager));
  ASSERT_TRUE(manager.objects().empty());
  EXPECT_EQ(manager.process(hand, hand_cluster, {}).created, (std::vector<std::int32_t>{1}));
}

// A steady neighbour (cluster 0, id 1) and, in cluster 1, the first columns (of 10, 5 mm apart) of a block with a red
// end (its first two columns) and a blue rest, shifted by y: the returning object of the re-identification tests.
std::pair<ColoredCloud, std::vector<std::int32_t>> returning_block(int columns, float y = 0.f) {
  ColoredCloud cloud;
  std::vector<std::int32_t> cluster;
  add_block(cloud, cluster, 0, {-0.2f, 0.f, 1.f}, {12, 12, 6});
  const std::size_t first = cloud.size();
  add_block(cloud, cluster, 1, {0.1f, y, 1.f}, {columns, 14, 6});
  for (std::size_t i = first; i < cloud.size(); ++i) {
    cloud.colors[i] = cloud.positions[i].x() < 0.1f + 0.0075f ? Rgb8{200, 30, 35} : Rgb8{35, 70, 200};
  }
  return std::make_pair(cloud, cluster);
}

// Options under which only growth changes models and retirement takes two frames.
ObjectManagerOptions returning_options() {
  ObjectManagerOptions options;
  options.support.max_frames = 2;
  options.new_objects.confirm_frames = 1;
  options.model_update.alpha = 0.f;  // models change by growth alone
  return options;
}

// A manager under options that saw the whole block (id 2), then the neighbour alone until the block retired, then the
// block's red end (2 columns) come back: a new object, id 3.
std::unique_ptr<ObjectManager> with_a_piece_returned(const ObjectManagerOptions& options) {
  auto manager = std::make_unique<ObjectManager>(options);
  const auto [whole, whole_cluster] = returning_block(10);
  manager->process(whole, whole_cluster, {});
  ColoredCloud neighbour;
  std::vector<std::int32_t> neighbour_cluster;
  add_block(neighbour, neighbour_cluster, 0, {-0.2f, 0.f, 1.f}, {12, 12, 6});
  for (int t = 0; t < 2; ++t) manager->process(neighbour, neighbour_cluster, unchanged(*manager));
  EXPECT_EQ(manager->objects().count(2), 0u);
  const auto [piece, piece_cluster] = returning_block(2);
  EXPECT_EQ(manager->process(piece, piece_cluster, unchanged(*manager)).created, (std::vector<std::int32_t>{3}));
  return manager;
}

TEST(ObjectManager, AReturningObjectFirstSeenInAPieceTakesItsIdBackOnceGrown) {
  // A mostly blue block with a red end leaves the view and is retired. It comes back red end first: that piece's
  // colours match nothing, so it is a new object. Next frame the whole block shows: the new object grows by the
  // blue rest, and the grown model matches the remembered one, whose id it takes back.
  const auto [whole, whole_cluster] = returning_block(10);
  const auto manager = with_a_piece_returned(returning_options());
  const ObjectManagerFrame& grown = manager->process(whole, whole_cluster, unchanged(*manager));
  EXPECT_EQ(grown.created, (std::vector<std::int32_t>{2}));
  EXPECT_EQ(grown.retired, (std::vector<std::int32_t>{3}));
  EXPECT_EQ(grown.reidentified, (std::vector<std::pair<std::int32_t, std::int32_t>>{{3, 2}}));
  ASSERT_EQ(manager->objects().count(2), 1u);
  EXPECT_EQ(manager->objects().count(3), 0u);
  const ManagedObject& back = manager->objects().at(2);
  // The grown model: the piece and the rest but what tau segmented next to the piece.
  const std::size_t piece_points = 2u * 14u * 6u;
  EXPECT_GT(back.model.cloud.size(), 3 * piece_points);
  for (std::size_t i = 0; i < whole.size(); ++i) EXPECT_EQ(grown.labels[i], whole_cluster[i] == 0 ? 1 : 2);
  // It is no longer new: growing again takes no other id.
  EXPECT_TRUE(manager->process(whole, whole_cluster, unchanged(*manager)).created.empty());

  // Only objects retired by the new one's birth: the piece shows elsewhere while the block is still tracked
  // (unsupported), the block retires a frame later. Two objects seen at once are not one.
  ObjectManager later(returning_options());
  later.process(whole, whole_cluster, {});
  const auto [moved_piece, moved_piece_cluster] = returning_block(2, 0.2f);
  EXPECT_EQ(later.process(moved_piece, moved_piece_cluster, unchanged(later)).created, (std::vector<std::int32_t>{3}));
  EXPECT_EQ(later.process(moved_piece, moved_piece_cluster, unchanged(later)).retired, (std::vector<std::int32_t>{2}));
  const auto [moved_whole, moved_whole_cluster] = returning_block(10, 0.2f);
  EXPECT_TRUE(later.process(moved_whole, moved_whole_cluster, unchanged(later)).created.empty());
  EXPECT_EQ(later.objects().count(3), 1u);
  EXPECT_GT(later.objects().at(3).model.cloud.size(), 3 * piece_points);  // it grew
}

TEST(ObjectManager, AReturningObjectIsReidentifiedOnlyOnceEnoughOfItHasGrown) {
  // The red-ended blue block of the test above comes back red end first (2 of its 10 columns), then 6 columns show
  // (its colours match already; the model grows by the 2 beyond tau of the piece), then all of it. With
  // reidentify_grown_min_share 0.5 that model, 0.4 of the remembered one, is too little to register it on: the id
  // comes back only with the whole block (0.6).
  const auto [whole, whole_cluster] = returning_block(10);
  const auto [half, half_cluster] = returning_block(6);
  // The manager after the 6 columns showed, and that frame's reidentified list.
  auto run = [&](float min_share) {
    ObjectManagerOptions options = returning_options();
    options.reidentify_grown_min_share = min_share;
    auto manager = with_a_piece_returned(options);
    const ObjectManagerFrame half_frame = manager->process(half, half_cluster, unchanged(*manager));
    return std::make_pair(std::move(manager), half_frame.reidentified);
  };
  using Pairs = std::vector<std::pair<std::int32_t, std::int32_t>>;

  // Without the floor the 6 columns take the id back.
  EXPECT_EQ(run(0.f).second, (Pairs{{3, 2}}));

  auto [manager, at_half] = run(0.5f);
  EXPECT_TRUE(at_half.empty());
  ASSERT_EQ(manager->objects().count(3), 1u);
  EXPECT_NEAR(static_cast<float>(manager->objects().at(3).model.cloud.size()) / (10.f * 14.f * 6.f), 0.4f, 1e-6f);
  const ObjectManagerFrame& at_whole = manager->process(whole, whole_cluster, unchanged(*manager));
  EXPECT_EQ(at_whole.reidentified, (Pairs{{3, 2}}));
  EXPECT_EQ(manager->objects().count(2), 1u);
  EXPECT_EQ(manager->objects().count(3), 0u);
}

TEST(ObjectManager, ANewClusterBecomesAnObjectAfterPersisting) {
  TwoBlocks scene;
  ObjectManagerOptions options;
  options.new_objects.confirm_frames = 3;
  ObjectManager manager(options);
  manager.process(scene.cloud, scene.cluster, {});
  add_block(scene.cloud, scene.cluster, 2, {0.f, 0.2f, 1.f}, {8, 8, 6});
  std::vector<std::int32_t> created;
  for (int t = 0; t < 3; ++t) {
    const auto& frame = manager.process(scene.cloud, scene.cluster, unchanged(manager));
    created.insert(created.end(), frame.created.begin(), frame.created.end());
    if (t < 2) {
      EXPECT_TRUE(frame.created.empty()) << "created before persisting, frame " << t;
    }
  }
  EXPECT_EQ(created, (std::vector<std::int32_t>{3}));
}

TEST(ObjectManager, AHeldObjectsOwnPointsAreNoNewObject) {
  // The first block (5.5 cm across) moves 8 cm while its tracker holds its estimate where it was (a box turned
  // inside a hand whose claims cover it): its points are unexplained (none within tau of its model, so none
  // propagates a label) and persist, inside its bounding sphere (4.1 cm) grown by 8 cm.
  for (const bool held : {true, false}) {
    TwoBlocks scene;
    ObjectManagerOptions options;
    options.new_objects.confirm_frames = 3;
    options.held_birth_margin = 0.08f;
    ObjectManager manager(options);
    manager.process(scene.cloud, scene.cluster, {});
    ColoredCloud moved_scene = scene.cloud;
    for (std::size_t i = 0; i < moved_scene.size(); ++i) {
      if (scene.cluster[i] == 0) moved_scene.positions[i].y() += 0.08f;
    }
    std::vector<std::int32_t> created;
    for (int t = 0; t < 4; ++t) {
      std::map<std::int32_t, ObjectEstimate> estimates = unchanged(manager);
      estimates.at(1).held = held;
      const auto& frame = manager.process(moved_scene, scene.cluster, estimates);
      created.insert(created.end(), frame.created.begin(), frame.created.end());
    }
    // Held: they are its own points, waiting for its tracker; not held, a persisting unexplained cluster is new.
    EXPECT_EQ(created.empty(), held) << "held " << held;
  }
  ObjectManagerOptions bad;
  bad.held_birth_margin = -0.01f;
  EXPECT_THROW(ObjectManager{bad}, std::invalid_argument);
}

TEST(ObjectManager, AYoungObjectGrowsByPointsConnectedOnlyToIt) {
  // An arm reaching in: first its tip is seen, then more of it, connected to the tip.
  ColoredCloud cloud;
  std::vector<std::int32_t> cluster;
  add_block(cloud, cluster, 0, {0.f, 0.f, 1.f}, {8, 8, 4});
  ObjectManager manager;
  manager.process(cloud, cluster, {});
  ASSERT_EQ(manager.objects().size(), 1u);
  const std::size_t tip_points = cloud.size();
  add_block(cloud, cluster, 0, {0.04f, 0.f, 1.f}, {24, 8, 4});
  const auto& frame = manager.process(cloud, cluster, unchanged(manager));
  EXPECT_TRUE(frame.created.empty());
  EXPECT_EQ(manager.objects().size(), 1u);
  for (const std::int32_t label : frame.labels) EXPECT_EQ(label, 1);
  EXPECT_GT(manager.objects().at(1).model.cloud.size(), tip_points);

  // Growth and propagation off: the same arm makes a second object once it persists.
  ObjectManagerOptions options;
  options.growth_frames = 0;
  options.propagation_radius = 0.f;
  options.new_objects.confirm_frames = 1;
  ObjectManager strict(options);
  ColoredCloud tip;
  std::vector<std::int32_t> tip_cluster;
  add_block(tip, tip_cluster, 0, {0.f, 0.f, 1.f}, {8, 8, 4});
  strict.process(tip, tip_cluster, {});
  strict.process(cloud, cluster, unchanged(strict));
  EXPECT_EQ(strict.objects().size(), 2u);
}

TEST(ObjectManager, AClusterOffTheTableCarriesATrackedObjectsLabelButNeverBecomesAnObject) {
  // Clusters [0, 1) stand on the table; cluster 1 does not (a wall beside the table, then an arm raised beyond its far
  // edge).
  ColoredCloud cloud;
  std::vector<std::int32_t> cluster;
  add_block(cloud, cluster, 0, {-0.2f, 0.f, 1.f}, {8, 8, 4});
  add_block(cloud, cluster, 1, {0.2f, 0.f, 1.f}, {8, 8, 4});
  ObjectManagerOptions options;
  options.new_objects.confirm_frames = 1;
  ObjectManager manager(options);
  const auto& first = manager.process(cloud, cluster, 1, {});
  EXPECT_EQ(first.created, (std::vector<std::int32_t>{1}));
  for (int t = 0; t < 3; ++t) {
    const auto& frame = manager.process(cloud, cluster, 1, unchanged(manager));
    EXPECT_TRUE(frame.created.empty()) << "frame " << t;
  }
  ASSERT_EQ(manager.objects().size(), 1u);

  // The object's own cluster reaches off the table: the young object (the arm's tip) labels the rest of it and grows
  // by it, as it would on the table.
  const std::size_t tip_points = manager.objects().at(1).model.cloud.size();
  ColoredCloud raised;
  std::vector<std::int32_t> raised_cluster;
  add_block(raised, raised_cluster, 0, {0.2f, 0.f, 1.f}, {8, 8, 4});  // the wall, standing alone: cluster 0
  add_block(raised, raised_cluster, 1, {-0.2f, 0.f, 1.f}, {8, 8, 4});
  add_block(raised, raised_cluster, 1, {-0.16f, 0.f, 1.f}, {24, 8, 4});
  const auto& frame = manager.process(raised, raised_cluster, 0, unchanged(manager));
  EXPECT_TRUE(frame.created.empty());
  for (std::size_t i = 0; i < raised.size(); ++i) EXPECT_EQ(frame.labels[i], raised_cluster[i] == 1 ? 1 : 0) << i;
  EXPECT_GT(manager.objects().at(1).model.cloud.size(), tip_points);
  EXPECT_THROW(manager.process(raised, raised_cluster, -1, {}), std::invalid_argument);
}

TEST(ObjectManager, APartEnteringTheViewInAClusterOfItsOwnWithAnObjectThatJustEnteredIsThatObjects) {
  // A block at rest from the first frame; then a palm enters (born at frame 1), then a finger 2 cm from it in a
  // cluster of its own.
  const auto run = [](int finger_frame, const Eigen::Vector3f& finger_at, int entering_frames) {
    ObjectManagerOptions options;
    options.new_objects.confirm_frames = 1;
    options.entering_frames = entering_frames;
    options.entering_distance = 0.03f;
    ObjectManager manager(options);
    ColoredCloud cloud;
    std::vector<std::int32_t> cluster;
    add_block(cloud, cluster, 0, {-0.2f, 0.f, 1.f}, {8, 8, 4});
    manager.process(cloud, cluster, {});
    add_block(cloud, cluster, 1, {0.1f, 0.f, 1.f}, {8, 8, 4});  // the palm: x in [0.1, 0.135]
    manager.process(cloud, cluster, unchanged(manager));
    EXPECT_EQ(manager.objects().size(), 2u);
    for (int t = 2; t < finger_frame; ++t) manager.process(cloud, cluster, unchanged(manager));
    const std::size_t palm_points = manager.objects().at(2).model.cloud.size();
    const std::size_t before = cloud.size();
    add_block(cloud, cluster, 2, finger_at, {3, 8, 4});
    const ObjectManagerFrame frame = manager.process(cloud, cluster, unchanged(manager));
    std::set<std::int32_t> finger_labels;
    for (std::size_t i = before; i < cloud.size(); ++i) finger_labels.insert(frame.labels[i]);
    return std::make_tuple(frame.created, finger_labels, manager.objects().at(2).model.cloud.size() > palm_points);
  };
  const Eigen::Vector3f beside_palm(0.155f, 0.f, 1.f);  // 2 cm beyond the palm's edge
  const auto [created, labels, grown] = run(2, beside_palm, 10);
  EXPECT_TRUE(created.empty());
  EXPECT_EQ(labels, (std::set<std::int32_t>{2}));
  EXPECT_TRUE(grown);
  // Off, too late after the palm's birth, too far from it, or beside an object that was there from the first frame:
  // an object of its own.
  EXPECT_EQ(std::get<0>(run(2, beside_palm, 0)), (std::vector<std::int32_t>{3}));
  EXPECT_EQ(std::get<0>(run(13, beside_palm, 10)), (std::vector<std::int32_t>{3}));
  EXPECT_EQ(std::get<0>(run(2, Eigen::Vector3f(0.175f, 0.f, 1.f), 10)), (std::vector<std::int32_t>{3}));
  EXPECT_EQ(std::get<0>(run(2, Eigen::Vector3f(-0.145f, 0.f, 1.f), 10)), (std::vector<std::int32_t>{3}));
}

TEST(ObjectManager, AFullModelThinsOutEvenlyToTakeInANewPart) {
  // A flat tip fills the model; the arm then reaching 25 cm further must still be covered by it,
  // so that tau segments the arm even where the clustering splits it off.
  ColoredCloud cloud;
  std::vector<std::int32_t> cluster;
  add_block(cloud, cluster, 0, {0.f, 0.f, 1.f}, {10, 10, 1});
  ObjectManagerOptions options;
  options.max_model_points = 100;
  ObjectManager manager(options);
  manager.process(cloud, cluster, {});
  ASSERT_EQ(manager.objects().at(1).model.cloud.size(), 100u);
  add_block(cloud, cluster, 0, {0.05f, 0.f, 1.f}, {50, 10, 1});
  manager.process(cloud, cluster, unchanged(manager));
  const ManagedObject& arm = manager.objects().at(1);
  ASSERT_LE(arm.model.cloud.size(), 100u);
  ASSERT_EQ(arm.model.features.size(), arm.model.cloud.size());
  const Eigen::Isometry3f to_camera = arm.pose.isometry();
  float far_x = -1.f, near_x = 1.f;
  for (const Eigen::Vector3f& p : arm.model.cloud.positions) {
    far_x = std::max(far_x, (to_camera * p).x());
    near_x = std::min(near_x, (to_camera * p).x());
  }
  EXPECT_GT(far_x, 0.05f + 0.005f * 49 - 0.015f);  // the arm's end
  EXPECT_LT(near_x, 0.01f);                        // the tip is kept

  // Without clusters (no propagation) tau alone segments nearly all of the arm.
  const auto& frame = manager.process(cloud, std::vector<std::int32_t>(cloud.size(), -1), unchanged(manager));
  std::size_t labelled = 0;
  for (const std::int32_t label : frame.labels) labelled += label == 1 ? 1 : 0;
  EXPECT_GT(labelled, cloud.size() * 9 / 10);
}

TEST(ObjectManager, UnexplainedPointsOfAContactClusterGoToTheObjectTheyConnectTo) {
  // Two objects in contact in one cluster (a hand holding a box), then the arm behind the hand
  // comes into view: connected to the hand only, it is the hand's, never the box's.
  ColoredCloud cloud;
  std::vector<std::int32_t> cluster;
  add_block(cloud, cluster, 0, {-0.1f, 0.f, 1.f}, {10, 10, 6});  // box
  add_block(cloud, cluster, 1, {0.0f, 0.f, 1.f}, {6, 10, 6});    // hand, touching the box
  ObjectManagerOptions options;
  options.growth_frames = 10;
  options.propagation_min_seed_share =
      0.1f;  // left alone by the guard: box and hand seed 57 % of the cluster with the arm
  ObjectManager manager(options);
  manager.process(cloud, cluster, {});
  ASSERT_EQ(manager.objects().size(), 2u);
  const std::size_t box_model = manager.objects().at(1).model.cloud.size();
  const std::size_t hand_model = manager.objects().at(2).model.cloud.size();
  const std::size_t before = cloud.size();
  std::fill(cluster.begin(), cluster.end(), 0);
  add_block(cloud, cluster, 0, {0.03f, 0.f, 1.f}, {30, 6, 4});  // the arm, beyond tau of the hand
  const auto& frame = manager.process(cloud, cluster, unchanged(manager));
  EXPECT_TRUE(frame.created.empty());
  for (std::size_t i = before; i < cloud.size(); ++i) ASSERT_EQ(frame.labels[i], 2) << "arm point " << i;
  EXPECT_EQ(manager.objects().at(1).model.cloud.size(), box_model);
  EXPECT_GT(manager.objects().at(2).model.cloud.size(), hand_model);

  // Past growth_frames the hand still labels the arm, but its model no longer grows.
  for (int t = 0; t < 10; ++t) manager.process(cloud, cluster, unchanged(manager));
  const std::size_t grown = manager.objects().at(2).model.cloud.size();
  ColoredCloud longer = cloud;
  std::vector<std::int32_t> longer_cluster = cluster;
  add_block(longer, longer_cluster, 0, {0.18f, 0.f, 1.f}, {10, 6, 4});
  const auto& later = manager.process(longer, longer_cluster, unchanged(manager));
  for (std::size_t i = cloud.size(); i < longer.size(); ++i) ASSERT_EQ(later.labels[i], 2);
  EXPECT_EQ(manager.objects().at(2).model.cloud.size(), grown);

  // A gap wider than the radius stops the propagation.
  ObjectManagerOptions no_reach = options;
  no_reach.propagation_radius = 0.004f;
  ObjectManager short_reach(no_reach);
  ColoredCloud first(cloud);
  first.positions.resize(before);
  first.colors.resize(before);
  std::vector<std::int32_t> first_cluster(before, 0);
  short_reach.process(first, first_cluster, {});
  ColoredCloud gapped = first;
  std::vector<std::int32_t> gapped_cluster = first_cluster;
  add_block(gapped, gapped_cluster, 0, {0.05f, 0.f, 1.f}, {10, 6, 4});
  const auto& apart = short_reach.process(gapped, gapped_cluster, unchanged(short_reach));
  for (std::size_t i = before; i < gapped.size(); ++i) ASSERT_EQ(apart.labels[i], 0);
}

TEST(ObjectManager, AClusterSeededTooThinlyKeepsItsPointsForAnObjectOfItsOwn) {
  // A box a hand has put down, the hand leaving: one point of the hand, 1.2 cm from the box, falls in the box's
  // cluster. Propagated from that one point, the whole box would take the hand's label (and never become an object
  // again); with propagation_min_seed_share the box's points stay free and become an object.
  ColoredCloud hand;
  std::vector<std::int32_t> hand_cluster;
  add_block(hand, hand_cluster, 0, {-0.1f, 0.f, 1.f}, {10, 10, 6});  // object 1; its last column at x = -0.055
  ColoredCloud scene = hand;
  std::vector<std::int32_t> scene_cluster = hand_cluster;
  const std::size_t first_box = scene.size();
  add_block(scene, scene_cluster, 1, {-0.043f, 0.f, 1.f}, {10, 10, 6});  // beyond tau, within the propagation radius
  const std::size_t seed = (9 * 10 + 0) * 6 + 0;                         // the hand's point at x = -0.055, y = z = 0
  scene_cluster[seed] = 1;
  for (const float share : {0.f, 0.1f}) {
    ObjectManagerOptions options;
    options.new_objects.confirm_frames = 1;
    options.propagation_min_seed_share = share;
    ObjectManager manager(options);
    manager.process(hand, hand_cluster, {});
    const ObjectManagerFrame& frame = manager.process(scene, scene_cluster, unchanged(manager));
    EXPECT_EQ(frame.labels[seed], 1);
    if (share == 0.f) {
      EXPECT_TRUE(frame.created.empty());
      for (std::size_t i = first_box; i < scene.size(); ++i) ASSERT_EQ(frame.labels[i], 1) << "box point " << i;
    } else {
      EXPECT_EQ(frame.created, (std::vector<std::int32_t>{2}));
      for (std::size_t i = first_box; i < scene.size(); ++i) ASSERT_EQ(frame.labels[i], 2) << "box point " << i;
    }
  }
  ObjectManagerOptions bad;
  bad.propagation_min_seed_share = 1.5f;
  EXPECT_THROW(ObjectManager{bad}, std::invalid_argument);
}

TEST(ObjectManager, RejectsInvalidOptionsAndInputs) {
  ObjectManagerOptions options;
  options.max_model_points = 10;
  options.min_object_points = 20;
  EXPECT_THROW(ObjectManager{options}, std::invalid_argument);
  ObjectManagerOptions far;
  far.propagation_radius = 0.5f;
  EXPECT_THROW(ObjectManager{far}, std::invalid_argument);
  for (const auto& [frames, distance] :
       {std::pair{-1, 0.03f}, std::pair{1001, 0.03f}, std::pair{10, 0.f}, std::pair{10, 0.2f}}) {
    ObjectManagerOptions entering;
    entering.entering_frames = frames;
    entering.entering_distance = distance;
    test::expect_invalid_argument([&] { ObjectManager{entering}; }, "entering_");
  }
  ObjectManager manager;
  TwoBlocks scene;
  scene.cluster.pop_back();
  EXPECT_THROW(manager.process(scene.cloud, scene.cluster, {}), std::invalid_argument);
}

}  // namespace
}  // namespace mfot

namespace mfot {
namespace {

// Two blocks side by side as one cluster, split by the stand-in discovery: objects 1 and 2, born
// together.
struct BornTogether {
  ColoredCloud cloud;
  std::vector<std::int32_t> cluster;
  BornTogether() { add_block(cloud, cluster, 0, {-0.0275f, 0.f, 1.f}, {12, 12, 6}); }
};

ObjectManagerOptions join_options() {
  ObjectManagerOptions options;
  options.model_update.alpha = 0.f;  // models stay as born: the joined one is checked point by point
  options.join_split.join_frames = 5;
  options.join_split.join_min_motion = 0.02f;
  return options;
}

// Every object moved by offset (its estimate), the scene moved alike.
std::map<std::int32_t, ObjectEstimate> moved(const ObjectManager& manager, const Eigen::Vector3f& offset,
                                             std::span<const std::int32_t> ids) {
  std::map<std::int32_t, ObjectEstimate> estimates;
  for (const auto& [id, object] : manager.objects()) {
    Pose pose = object.pose;
    if (std::find(ids.begin(), ids.end(), id) != ids.end()) pose.translation += offset;
    estimates[id] = {pose, 1.f};
  }
  return estimates;
}

ColoredCloud shifted(const ColoredCloud& cloud, const Eigen::Vector3f& offset) {
  ColoredCloud out = cloud;
  for (auto& p : out.positions) p += offset;
  return out;
}

TEST(ObjectManagerJoin, PartsBornTogetherThatMoveAsOneBecomeOneObject) {
  BornTogether scene;
  ObjectManager manager(join_options(), std::make_unique<SplitAtXZero>());
  manager.process(scene.cloud, scene.cluster, {});
  ASSERT_EQ(manager.objects().size(), 2u);
  const std::size_t model_points =
      manager.objects().at(1).model.cloud.size() + manager.objects().at(2).model.cloud.size();
  const std::vector<std::int32_t> both{1, 2};
  Eigen::Vector3f offset = Eigen::Vector3f::Zero();
  std::vector<std::pair<std::int32_t, std::int32_t>> joined;
  for (int frame = 1; frame <= 8 && joined.empty(); ++frame) {
    const auto estimates = moved(manager, {0.01f, 0.f, 0.f}, both);
    offset.x() += 0.01f;
    const auto& result = manager.process(shifted(scene.cloud, offset), scene.cluster, estimates);
    joined = result.joined;
    if (!joined.empty()) {
      EXPECT_EQ(result.retired, (std::vector<std::int32_t>{2}));
      for (const std::int32_t label : result.labels) EXPECT_EQ(label, 1);
    }
  }
  ASSERT_EQ(joined, (std::vector<std::pair<std::int32_t, std::int32_t>>{{1, 2}}));
  ASSERT_EQ(manager.objects().size(), 1u);
  const ManagedObject& whole = manager.objects().at(1);
  EXPECT_EQ(whole.model.cloud.size(), model_points);
  EXPECT_EQ(whole.model.features.size(), model_points);
  // The joined model at the kept pose covers both blocks: every scene point has a model point near.
  const Eigen::Isometry3f pose = whole.pose.isometry();
  const ColoredCloud now = shifted(scene.cloud, offset);
  for (std::size_t i = 0; i < now.size(); i += 37) {
    float nearest = 1.f;
    for (const auto& p : whole.model.cloud.positions) nearest = std::min(nearest, (pose * p - now.positions[i]).norm());
    EXPECT_LT(nearest, 1e-4f) << "scene point " << i;
  }
}

TEST(ObjectManagerJoin, StillOrSeparatelyMovingOrUnrelatedObjectsStayApart) {
  {  // born together, never moving
    BornTogether scene;
    ObjectManager manager(join_options(), std::make_unique<SplitAtXZero>());
    manager.process(scene.cloud, scene.cluster, {});
    for (int frame = 0; frame < 20; ++frame) manager.process(scene.cloud, scene.cluster, unchanged(manager));
    EXPECT_EQ(manager.objects().size(), 2u);
  }
  {  // born together, only one moving
    BornTogether scene;
    ObjectManager manager(join_options(), std::make_unique<SplitAtXZero>());
    manager.process(scene.cloud, scene.cluster, {});
    const std::vector<std::int32_t> one{1};
    for (int frame = 0; frame < 20; ++frame)
      manager.process(scene.cloud, scene.cluster, moved(manager, {0.005f, 0.f, 0.f}, one));
    EXPECT_EQ(manager.objects().size(), 2u);
  }
  {  // moving together, but born from different clusters (a hand carrying an object)
    TwoBlocks scene;
    ObjectManager manager(join_options());
    manager.process(scene.cloud, scene.cluster, {});
    const std::vector<std::int32_t> both{1, 2};
    for (int frame = 0; frame < 20; ++frame)
      manager.process(scene.cloud, scene.cluster, moved(manager, {0.01f, 0.f, 0.f}, both));
    EXPECT_EQ(manager.objects().size(), 2u);
  }
}

// The two blocks of scene born in the manager's first frame, then moved 1 cm a frame together for `frames` frames
// (seen, neither carried); returns the scene's offset.
Eigen::Vector3f moved_together(ObjectManager& manager, const BornTogether& scene, int frames) {
  manager.process(scene.cloud, scene.cluster, {});
  EXPECT_EQ(manager.objects().size(), 2u);
  const std::vector<std::int32_t> both{1, 2};
  Eigen::Vector3f offset = Eigen::Vector3f::Zero();
  for (int frame = 0; frame < frames; ++frame) {
    offset.x() += 0.01f;
    manager.process(shifted(scene.cloud, offset), scene.cluster, moved(manager, {0.01f, 0.f, 0.f}, both));
    EXPECT_EQ(manager.objects().at(1).carried_by, 0);
  }
  return offset;
}

// Two touching blocks born apart (a hand gripping a box, as far as the manager can tell) move 1 cm a
// frame together; then block 1's tracker holds it (hidden) while block 2 goes on: block 1 follows
// block 2 (carried_by 2) and its held frames without support do not retire it. With carry off it
// waits where it was last seen and, neither carried nor occluded (its points are simply gone), retires.
TEST(ObjectManagerCarry, AHeldObjectFollowsTheObjectItMovedWith) {
  for (const bool on : {true, false}) {
    SCOPED_TRACE(on ? "carry on" : "carry off");
    BornTogether scene;
    ObjectManagerOptions options;
    options.model_update.alpha = 0.f;
    options.carry.frames = on ? 3 : 0;
    options.carry.min_motion = 0.02f;
    options.hidden_occluded_share = 0.6f;
    options.support.max_frames = 2;
    ObjectManager manager(options, std::make_unique<SplitAtXZero>());
    Eigen::Vector3f offset = moved_together(manager, scene, 5);
    const Pose last_seen = manager.objects().at(1).pose;
    // Block 1 hidden: only block 2's points are in view; its tracker holds it.
    ColoredCloud visible;
    std::vector<std::int32_t> visible_cluster;
    for (std::size_t i = 0; i < scene.cloud.size(); ++i) {
      if (scene.cloud.positions[i].x() < 0.f) continue;
      visible.push_back(scene.cloud.positions[i], scene.cloud.colors[i]);
      visible_cluster.push_back(0);
    }
    for (int frame = 0; frame < 6; ++frame) {
      offset.x() += 0.01f;
      std::map<std::int32_t, ObjectEstimate> estimates =
          moved(manager, {0.01f, 0.f, 0.f}, std::vector<std::int32_t>{2});
      estimates.at(1).held = true;
      const auto& result = manager.process(shifted(visible, offset), visible_cluster, estimates);
      if (!on) {
        if (!result.retired.empty()) {
          EXPECT_EQ(result.retired, std::vector<std::int32_t>{1});
          EXPECT_EQ(frame, options.support.max_frames - 1);
          break;
        }
        ASSERT_LT(frame, options.support.max_frames);
      } else {
        EXPECT_TRUE(result.retired.empty()) << "frame " << frame;
      }
      const ManagedObject& hidden = manager.objects().at(1);
      EXPECT_TRUE(hidden.held);
      EXPECT_EQ(hidden.carried_by, on ? 2 : 0);
      const Eigen::Vector3f expected =
          last_seen.translation + (on ? 0.01f * static_cast<float>(frame + 1) : 0.f) * Eigen::Vector3f::UnitX();
      EXPECT_LT((hidden.pose.translation - expected).norm(), 1e-5f) << "frame " << frame;
    }
  }
}

// Block 1 carried by block 2 as above, then seen again 4 cm from where it was carried to (the carrier's motion a
// guess: a box brought back in a hand): its points lie beyond tau of its model, in a cluster of their own, and would
// be born as a new object. Its colours match the carried block's and its model registers on them: it takes the
// points and the registered pose, and nothing is born.
TEST(ObjectManagerCarry, ACarriedObjectSeenAwayFromItsCarriedPoseTakesItsPointsBack) {
  {
    BornTogether scene;
    ObjectManagerOptions options;
    options.model_update.alpha = 0.f;
    options.carry.frames = 3;
    options.carry.min_motion = 0.02f;
    options.hidden_occluded_share = 0.6f;
    options.new_objects.confirm_frames = 1;
    ObjectManager manager(options, std::make_unique<SplitAtXZero>());
    Eigen::Vector3f offset = moved_together(manager, scene, 5);
    ColoredCloud second_only;  // block 1 hidden
    ColoredCloud first_only;
    for (std::size_t i = 0; i < scene.cloud.size(); ++i) {
      (scene.cloud.positions[i].x() < 0.f ? first_only : second_only)
          .push_back(scene.cloud.positions[i], scene.cloud.colors[i]);
    }
    const auto held_first = [&](const Eigen::Vector3f& step) {
      std::map<std::int32_t, ObjectEstimate> estimates = moved(manager, step, std::vector<std::int32_t>{2});
      estimates.at(1).held = true;
      return estimates;
    };
    for (int frame = 0; frame < 2; ++frame) {
      offset.x() += 0.01f;
      manager.process(shifted(second_only, offset), std::vector<std::int32_t>(second_only.size(), 0),
                      held_first({0.01f, 0.f, 0.f}));
      ASSERT_EQ(manager.objects().at(1).carried_by, 2);
    }
    // Block 1 back, 4 cm short of where block 2 carried it, in its own cluster.
    offset.x() += 0.01f;
    ColoredCloud back = shifted(second_only, offset);
    std::vector<std::int32_t> cluster(back.size(), 0);
    const ColoredCloud first_back = shifted(first_only, offset - Eigen::Vector3f(0.04f, 0.f, 0.f));
    for (std::size_t i = 0; i < first_back.size(); ++i) {
      back.push_back(first_back.positions[i], first_back.colors[i]);
      cluster.push_back(1);
    }
    const ObjectManagerFrame& result = manager.process(back, cluster, held_first({0.01f, 0.f, 0.f}));
    const std::size_t first_begin = second_only.size();
    EXPECT_TRUE(result.created.empty());
    EXPECT_EQ(result.found_carried, (std::vector<std::int32_t>{1}));
    EXPECT_EQ(manager.objects().size(), 2u);
    for (std::size_t i = first_begin; i < back.size(); ++i) EXPECT_EQ(result.labels[i], 1) << "point " << i;
    // Its pose: where its points are, not where it was carried to.
    const ManagedObject& first = manager.objects().at(1);
    Eigen::Vector3f model_centroid = Eigen::Vector3f::Zero();
    for (const auto& p : first.model.cloud.positions) model_centroid += p;
    model_centroid /= static_cast<float>(first.model.cloud.size());
    Eigen::Vector3f seen_centroid = Eigen::Vector3f::Zero();
    for (const auto& p : first_back.positions) seen_centroid += p;
    seen_centroid /= static_cast<float>(first_back.size());
    EXPECT_LT((first.pose.isometry() * model_centroid - seen_centroid).norm(), 0.005f);
  }
}

// Two touching blocks born apart stay still while seen; then block 1's tracker holds it (its points
// still in view: claimed by block 2, say) while block 2 stays (the grip), and from frame 7 both move 1 cm
// a frame. No watch saw them move together, but once block 2 is min_motion (2 cm) off its grip, block
// 1's held place is seen through (the scene moved off it) and where block 2 would carry it is not: it
// is gripped away: retired at that frame (re-identified where it shows again). With seen_through_share 0 it
// waits where it was held.
TEST(ObjectManagerCarry, AHeldObjectWhosePlaceIsSeenThroughIsRetiredOnceGrippedAway) {
  enum class Mode { kOff, kRetire };
  for (const Mode mode : {Mode::kRetire, Mode::kOff}) {
    SCOPED_TRACE(mode == Mode::kOff ? "seen-through carry off" : "retired");
    BornTogether scene;
    ObjectManagerOptions options;
    options.model_update.alpha = 0.f;
    options.carry.frames = 3;
    options.carry.min_motion = 0.02f;
    options.carry.seen_through_share = mode == Mode::kOff ? 0.f : 0.2f;
    options.hidden_occluded_share = 0.6f;
    ObjectManager manager(options, std::make_unique<SplitAtXZero>());
    manager.process(scene.cloud, scene.cluster, {});
    ASSERT_EQ(manager.objects().size(), 2u);
    const Eigen::Vector3f still = Eigen::Vector3f::Zero();
    for (int frame = 1; frame <= 3; ++frame) {
      manager.process(scene.cloud, scene.cluster, moved(manager, still, std::vector<std::int32_t>{}));
    }
    const Pose held_at = manager.objects().at(1).pose;
    Eigen::Vector3f offset = Eigen::Vector3f::Zero();
    for (int frame = 4; frame <= 11; ++frame) {
      SCOPED_TRACE("frame " + std::to_string(frame));
      const Eigen::Vector3f step = frame >= 7 ? Eigen::Vector3f(0.01f, 0.f, 0.f) : still;
      offset += step;
      std::map<std::int32_t, ObjectEstimate> estimates = moved(manager, step, std::vector<std::int32_t>{2});
      if (estimates.contains(1)) estimates.at(1).held = true;
      const ObjectManagerFrame& result = manager.process(shifted(scene.cloud, offset), scene.cluster, estimates);
      const bool gripped_away = mode != Mode::kOff && frame >= 8;
      if (mode == Mode::kRetire) {
        const bool retired_now = std::find(result.retired.begin(), result.retired.end(), 1) != result.retired.end();
        EXPECT_EQ(retired_now, frame == 8);
        EXPECT_EQ(manager.objects().contains(1), frame < 8);
        if (gripped_away) continue;
      }
      const ManagedObject& hidden = manager.objects().at(1);
      EXPECT_EQ(hidden.carried_by, 0);
      EXPECT_LT((hidden.pose.translation - held_at.translation).norm(), 1e-5f);
    }
  }
}

// Two touching blocks: when block 2's estimate moves, block 1's companion is block 2 with its step (a
// translation: the same increment); block 2's is none (block 1 stayed). A step below min_motion, a held
// block (its estimate is not seen) and contact_distance 0 give none.
TEST(ObjectManagerCompanion, ATouchingObjectThatMovedIsTheCompanion) {
  for (const float contact : {0.02f, 0.f}) {
    SCOPED_TRACE(contact > 0.f ? "companions on" : "companions off");
    BornTogether scene;
    ObjectManagerOptions options;
    options.model_update.alpha = 0.f;
    options.companion.contact_distance = contact;
    ObjectManager manager(options, std::make_unique<SplitAtXZero>());
    manager.process(scene.cloud, scene.cluster, {});
    ASSERT_EQ(manager.objects().size(), 2u);
    const std::vector<std::int32_t> second{2};
    manager.process(scene.cloud, scene.cluster, moved(manager, {0.01f, 0.f, 0.f}, second));
    const ManagedObject& first = manager.objects().at(1);
    EXPECT_EQ(first.companion, contact > 0.f ? 2 : 0);
    const PoseVector expected = contact > 0.f ? (PoseVector() << 0.01f, 0, 0, 0, 0, 0).finished() : PoseVector::Zero();
    EXPECT_LT((first.companion_motion - expected).norm(), 1e-5f);
    EXPECT_EQ(manager.objects().at(2).companion, 0);
    if (contact == 0.f) continue;
    // A step below min_motion (2 mm by default).
    manager.process(scene.cloud, scene.cluster, moved(manager, {0.001f, 0.f, 0.f}, second));
    EXPECT_EQ(manager.objects().at(1).companion, 0);
    // A held block's estimate is not seen: it is no one's companion.
    std::map<std::int32_t, ObjectEstimate> held = moved(manager, {0.01f, 0.f, 0.f}, second);
    held.at(2).held = true;
    manager.process(scene.cloud, scene.cluster, held);
    EXPECT_EQ(manager.objects().at(1).companion, 0);
  }
  ObjectManagerOptions invalid;
  invalid.companion.contact_distance = 0.5f;
  EXPECT_THROW(ObjectManager{invalid}, std::invalid_argument);
}

TEST(ObjectManagerSplit, AnObjectWhosePartsLieInTwoClustersIsSplit) {
  // One cluster at birth: one object over both blocks.
  ColoredCloud cloud;
  std::vector<std::int32_t> cluster;
  add_block(cloud, cluster, 0, {-0.2f, 0.f, 1.f}, {12, 12, 6});
  add_block(cloud, cluster, 0, {-0.14f, 0.f, 1.f}, {10, 14, 6});
  ObjectManagerOptions options;
  options.join_split.split_frames = 3;
  options.join_split.split_min_gap = 0.004f;  // the blocks' facing sides are 5 mm apart
  // Later the clustering sees the blocks apart (pushed apart by less than tau: still segmented).
  std::vector<std::int32_t> apart(cluster.size(), 0);
  std::fill(apart.begin() + 12 * 12 * 6, apart.end(), 1);
  {  // parts closer than split_min_gap are one object however long they stay in two clusters
    ObjectManagerOptions close = options;
    close.join_split.split_min_gap = 0.03f;
    ObjectManager manager(close);
    manager.process(cloud, cluster, {});
    for (int frame = 1; frame <= 6; ++frame)
      EXPECT_TRUE(manager.process(cloud, apart, unchanged(manager)).split.empty());
  }
  ObjectManager manager(options);
  manager.process(cloud, cluster, {});
  ASSERT_EQ(manager.objects().size(), 1u);
  for (int frame = 1; frame <= 2; ++frame) {
    EXPECT_TRUE(manager.process(cloud, apart, unchanged(manager)).split.empty());
  }
  const auto& result = manager.process(cloud, apart, unchanged(manager));
  ASSERT_EQ(result.split, (std::vector<std::pair<std::int32_t, std::int32_t>>{{1, 2}}));
  EXPECT_EQ(result.created, (std::vector<std::int32_t>{2}));
  ASSERT_EQ(manager.objects().size(), 2u);
  // The larger block (12 x 12 x 6 points) keeps id 1 and a model of itself only.
  EXPECT_EQ(manager.objects().at(1).model.cloud.size(), 12u * 12u * 6u);
  EXPECT_EQ(manager.objects().at(2).model.cloud.size(), 10u * 14u * 6u);
  for (std::size_t i = 0; i < cloud.size(); ++i) EXPECT_EQ(result.labels[i], apart[i] == 0 ? 1 : 2);
}

TEST(ObjectManagerSplit, OnlyAPartThatDepartsFromTheObjectsMotionSplitsOff) {
  // Two blocks born as one object, later seen in two clusters while the object moves 5 mm a frame along x.
  ColoredCloud cloud;
  std::vector<std::int32_t> cluster;
  add_block(cloud, cluster, 0, {-0.2f, 0.f, 1.f}, {12, 12, 6});
  add_block(cloud, cluster, 0, {-0.14f, 0.f, 1.f}, {10, 14, 6});
  const std::size_t larger = 12u * 12u * 6u;
  std::vector<std::int32_t> apart(cluster.size(), 0);
  std::fill(apart.begin() + static_cast<std::ptrdiff_t>(larger), apart.end(), 1);
  ObjectManagerOptions options;
  options.segmentation.tau = 0.03f;  // the blocks stay segmented while they part by up to 3 cm
  options.join_split.split_frames = 3;
  options.join_split.split_min_gap = 0.004f;
  options.join_split.split_min_departure = 0.0175f;
  const auto frame_at = [&](float larger_dx, float smaller_dx) {
    ColoredCloud moved = cloud;
    for (std::size_t i = 0; i < moved.size(); ++i) moved.positions[i].x() += i < larger ? larger_dx : smaller_dx;
    return moved;
  };
  const auto estimate_at = [](const Pose& born, float dx) {
    Pose pose = born;
    pose.translation.x() += dx;
    return std::map<std::int32_t, ObjectEstimate>{{1, {pose, 1.f}}};
  };
  {  // both blocks move with the object's estimate: one body seen in two clusters, never split
    ObjectManager manager(options);
    manager.process(cloud, cluster, {});
    const Pose born = manager.objects().at(1).pose;
    for (int frame = 1; frame <= 10; ++frame) {
      const float dx = 0.005f * static_cast<float>(frame);
      EXPECT_TRUE(manager.process(frame_at(dx, dx), apart, estimate_at(born, dx)).split.empty()) << "frame " << frame;
    }
    EXPECT_EQ(manager.objects().size(), 1u);
  }
  // The smaller block stays where it was: it has departed 5 mm a frame from the object's motion since frame 1,
  // 15 mm at frame 4, 20 mm at frame 5.
  ObjectManager manager(options);
  manager.process(cloud, cluster, {});
  const Pose born = manager.objects().at(1).pose;
  for (int frame = 1; frame <= 4; ++frame) {
    const float dx = -0.005f * static_cast<float>(frame);  // away from the smaller block
    EXPECT_TRUE(manager.process(frame_at(dx, 0.f), apart, estimate_at(born, dx)).split.empty()) << "frame " << frame;
  }
  const auto& result = manager.process(frame_at(-0.025f, 0.f), apart, estimate_at(born, -0.025f));
  ASSERT_EQ(result.split, (std::vector<std::pair<std::int32_t, std::int32_t>>{{1, 2}}));
  for (std::size_t i = 0; i < cloud.size(); ++i) EXPECT_EQ(result.labels[i], apart[i] == 0 ? 1 : 2);
  ObjectManagerOptions invalid;
  invalid.join_split.split_min_departure = 1.5f;
  EXPECT_THROW(ObjectManager{invalid}, std::invalid_argument);
  invalid.join_split.split_min_departure = 0.03f;
  invalid.join_split.split_min_gap = 0.f;  // parts could not be followed
  EXPECT_THROW(ObjectManager{invalid}, std::invalid_argument);
}

// A stand-in discovery told when to split and where: at each x of at_x while splitting (a point's side: how many of
// them it lies at or past), else one part; parts numbered by their first point, as ObjectDiscovery::split promises.
class SplitWhenTold final : public ObjectDiscovery {
 public:
  bool splitting = false;
  std::vector<float> at_x{0.f};
  int calls = 0;
  int split(std::span<const Eigen::Vector3f> positions, std::span<const Rgb8>, std::vector<int>& part) override {
    ++calls;
    part.assign(positions.size(), 0);
    if (!splitting) return 1;
    std::map<std::ptrdiff_t, int> part_of_side;
    for (std::size_t i = 0; i < positions.size(); ++i) {
      const std::ptrdiff_t side =
          std::count_if(at_x.begin(), at_x.end(), [&](float x) { return positions[i].x() >= x; });
      part[i] = part_of_side.try_emplace(side, static_cast<int>(part_of_side.size())).first->second;
    }
    return static_cast<int>(part_of_side.size());
  }
};

ObjectManagerOptions confirm_options() {
  ObjectManagerOptions options;
  options.model_update.alpha = 0.f;  // models stay as built: checked point by point
  options.discovery.confirm_frames = 5;
  options.discovery.confirm_votes = 2;
  options.discovery.min_part_points = 150;  // the test's blocks' halves are parts (the shipped 400 is a real scene's)
  return options;
}

TEST(ObjectManagerConfirm, AYoungObjectTheDiscoverySplitsInEnoughOfItsFirstFramesIsSplit) {
  BornTogether scene;  // one block across x = 0, one cluster
  auto discovery = std::make_unique<SplitWhenTold>();
  SplitWhenTold* told = discovery.get();
  ObjectManager manager(confirm_options(), std::move(discovery));
  manager.process(scene.cloud, scene.cluster, {});  // the birth frame's discovery finds one object
  ASSERT_EQ(manager.objects().size(), 1u);
  told->splitting = true;  // frame 1: one vote of the two it takes
  EXPECT_TRUE(manager.process(scene.cloud, scene.cluster, unchanged(manager)).split.empty());
  told->splitting = false;  // frame 2: none
  EXPECT_TRUE(manager.process(scene.cloud, scene.cluster, unchanged(manager)).split.empty());
  told->splitting = true;  // frame 3: the second vote splits it; of the two equal halves the first (x < 0) keeps id 1
  const auto& result = manager.process(scene.cloud, scene.cluster, unchanged(manager));
  ASSERT_EQ(result.split, (std::vector<std::pair<std::int32_t, std::int32_t>>{{1, 2}}));
  EXPECT_EQ(result.created, (std::vector<std::int32_t>{2}));
  EXPECT_TRUE(result.regrouped.empty());
  ASSERT_EQ(manager.objects().size(), 2u);
  EXPECT_EQ(manager.objects().at(1).model.cloud.size(), 6u * 12u * 6u);  // rebuilt from its part
  EXPECT_EQ(manager.objects().at(2).model.cloud.size(), 6u * 12u * 6u);
  for (std::size_t i = 0; i < scene.cloud.size(); ++i)
    EXPECT_EQ(result.labels[i], scene.cloud.positions[i].x() < 0.f ? 1 : 2);
  // The objects born from one cluster are looked at together, once a frame, while one of them is in its first
  // confirm_frames frames: object 1 up to frame 5, object 2 (born at frame 3, its sibling) on frames 4 to 8.
  told->splitting = false;
  int calls = told->calls;
  for (int frame = 4; frame <= 8; ++frame) manager.process(scene.cloud, scene.cluster, unchanged(manager));
  EXPECT_EQ(told->calls - calls, 5);
  calls = told->calls;
  manager.process(scene.cloud, scene.cluster, unchanged(manager));
  EXPECT_EQ(told->calls, calls);
  EXPECT_EQ(manager.objects().size(), 2u);
}

TEST(ObjectManagerConfirm, AnObjectThatMovedFromWhereItWasBornIsNotLookedAtAgain) {
  BornTogether scene;
  auto discovery = std::make_unique<SplitWhenTold>();
  SplitWhenTold* told = discovery.get();
  ObjectManager manager(confirm_options(), std::move(discovery));  // confirm_max_motion 1 cm
  manager.process(scene.cloud, scene.cluster, {});
  told->splitting = true;
  const int calls = told->calls;
  // Moved 2 cm (a hand reaching in shows new parts of itself): never split by the discovery again.
  const Eigen::Vector3f offset(0.02f, 0.f, 0.f);
  const ColoredCloud moved_scene = shifted(scene.cloud, offset);
  const std::vector<std::int32_t> ids{1};
  for (int frame = 1; frame <= 4; ++frame) {
    EXPECT_TRUE(
        manager.process(moved_scene, scene.cluster, moved(manager, frame == 1 ? offset : Eigen::Vector3f::Zero(), ids))
            .split.empty());
  }
  EXPECT_EQ(told->calls, calls);
  EXPECT_EQ(manager.objects().size(), 1u);
}

TEST(ObjectManagerConfirm, APartThatIsOneConvexPieceWithASiblingJoinsIt) {
  BornTogether scene;  // block columns at x = -0.0275 + 0.005 k
  auto discovery = std::make_unique<SplitWhenTold>();
  SplitWhenTold* told = discovery.get();
  told->splitting = true;
  told->at_x = {0.02f};  // the birth frame cuts too far right: object 1 takes the four columns in [0, 0.02)
  ObjectManager manager(confirm_options(), std::move(discovery));
  manager.process(scene.cloud, scene.cluster, {});
  ASSERT_EQ(manager.objects().size(), 2u);
  const std::size_t born_second = manager.objects().at(2).model.cloud.size();
  ASSERT_EQ(born_second, 2u * 12u * 6u);
  told->at_x = {0.f};  // later frames cut at x = 0: the strip is one piece with object 2's points
  manager.process(scene.cloud, scene.cluster, unchanged(manager));
  const auto& result = manager.process(scene.cloud, scene.cluster, unchanged(manager));
  EXPECT_TRUE(result.split.empty());
  EXPECT_TRUE(result.created.empty());
  ASSERT_EQ(result.regrouped, (std::vector<std::pair<std::int32_t, std::int32_t>>{{1, 2}}));
  for (std::size_t i = 0; i < scene.cloud.size(); ++i)
    EXPECT_EQ(result.labels[i], scene.cloud.positions[i].x() < 0.f ? 1 : 2);
  EXPECT_EQ(manager.objects().at(1).model.cloud.size(), 6u * 12u * 6u);
  EXPECT_EQ(manager.objects().at(2).model.cloud.size(), born_second + 4u * 12u * 6u);
}

// Two objects the birth frame cut out of one block, then the discovery's parts in each of the confirm_frames frames
// after (true: it cuts at x = 0 again, false: one part); returns the manager after the frame in which they leave the
// confirmation (confirm_frames 5, votes 2: joined when together in all of at least 4 frames).
struct CutAtBirth {
  BornTogether scene;
  std::unique_ptr<ObjectManager> manager;
  ObjectManagerFrame last;
  explicit CutAtBirth(const std::vector<bool>& cut_in_frame) {
    auto discovery = std::make_unique<SplitWhenTold>();
    SplitWhenTold* told = discovery.get();
    manager = std::make_unique<ObjectManager>(confirm_options(), std::move(discovery));
    told->splitting = true;
    manager->process(scene.cloud, scene.cluster, {});
    for (const bool cut : cut_in_frame) {
      told->splitting = cut;
      last = manager->process(scene.cloud, scene.cluster, unchanged(*manager));
    }
  }
};

TEST(ObjectManagerConfirm, SiblingsTheDiscoveryNeverToldApartAgainAreJoinedWhenTheirFirstFramesEnd) {
  // Frames 1-5 find the block whole; frame 6 is past confirm_frames.
  const std::vector<bool> whole(6, false);
  CutAtBirth on(whole);
  ASSERT_EQ(on.last.joined, (std::vector<std::pair<std::int32_t, std::int32_t>>{{1, 2}}));  // equal halves: 1 kept
  EXPECT_EQ(on.last.retired, (std::vector<std::int32_t>{2}));
  ASSERT_EQ(on.manager->objects().size(), 1u);
  EXPECT_EQ(on.manager->objects().at(1).model.cloud.size(), 12u * 12u * 6u);
  for (const std::int32_t label : on.last.labels) EXPECT_EQ(label, 1);
}

TEST(ObjectManagerConfirm, SiblingsToldApartInOneFrameOrSeenTooFewFramesTogetherStayApart) {
  CutAtBirth apart_once({false, false, true, false, false, false});  // one vote of two: no split either
  EXPECT_TRUE(apart_once.last.joined.empty());
  EXPECT_EQ(apart_once.manager->objects().size(), 2u);
  // Together in every frame, but object 1 (x < 0) is taken 2 cm away after three (a hand took it): the pair is
  // decided then, on three frames of the four it takes, and forgotten.
  CutAtBirth still({false, false, false});
  ColoredCloud taken = still.scene.cloud;
  for (auto& p : taken.positions) {
    if (p.x() < 0.f) p.x() -= 0.02f;
  }
  const std::vector<std::int32_t> first{1};
  EXPECT_TRUE(still.manager->process(taken, still.scene.cluster, moved(*still.manager, {-0.02f, 0.f, 0.f}, first))
                  .joined.empty());
  for (int frame = 0; frame < 3; ++frame) {
    EXPECT_TRUE(still.manager->process(taken, still.scene.cluster, unchanged(*still.manager)).joined.empty());
  }
  EXPECT_EQ(still.manager->objects().size(), 2u);
}

TEST(ObjectManagerConfirm, ThreePiecesOfOneBirthNeverToldApartAgainBecomeOne) {
  BornTogether scene;
  auto discovery = std::make_unique<SplitWhenTold>();
  SplitWhenTold* told = discovery.get();
  ObjectManager manager(confirm_options(), std::move(discovery));
  told->splitting = true;
  told->at_x = {-0.01f, 0.01f};  // four columns each
  manager.process(scene.cloud, scene.cluster, {});
  ASSERT_EQ(manager.objects().size(), 3u);
  told->splitting = false;
  ObjectManagerFrame last;
  for (int frame = 1; frame <= 6; ++frame) last = manager.process(scene.cloud, scene.cluster, unchanged(manager));
  // Pairs (1, 2), (1, 3), (2, 3): 2 and 3 join 1, and the last pair is already one object.
  EXPECT_EQ(last.joined, (std::vector<std::pair<std::int32_t, std::int32_t>>{{1, 2}, {1, 3}}));
  ASSERT_EQ(manager.objects().size(), 1u);
  for (const std::int32_t label : last.labels) EXPECT_EQ(label, 1);
}

TEST(DiscoveryOptions, RejectsConfirmVotesBeyondItsFrames) {
  DiscoveryOptions o;
  o.confirm_frames = 5;
  o.confirm_votes = 6;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o.confirm_votes = 0;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o.confirm_votes = 5;
  EXPECT_NO_THROW(o.validate());
  o.confirm_frames = 0;  // off: the votes do not matter
  EXPECT_NO_THROW(o.validate());
  o.confirm_frames = -1;
  EXPECT_THROW(o.validate(), std::invalid_argument);
}

TEST(JoinSplitOptions, RejectsOutOfRangeFields) {
  JoinSplitOptions o;
  o.join_frames = -1;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o = {};
  o.split_min_share = 0.6f;
  EXPECT_THROW(o.validate(), std::invalid_argument);
}

// A box whose first view shows its +x, +y and +z faces (5 mm spacing), then, sampled elsewhere (as a sensor samples
// a surface between the model's points), those faces and its -y face, grown with an estimate 3 degrees off: the grown
// face is misplaced by that in the object frame; one more frame with the right estimate shows both parts.
struct BoxGrownOff {
  ColoredCloud first_view;
  ColoredCloud whole;          // the first view's faces, then the -y face, sampled between the first view's points
  std::size_t grown_from = 0;  // whole's first -y face point
  std::vector<std::int32_t> first_cluster, whole_cluster;
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
  BoxGrownOff() {
    const Eigen::Vector3f centre(0.02f, -0.01f, 0.9f);
    const auto on_plus_face = [](const Eigen::Vector3f& local) {
      return test::face_normal(local, test::kTestObjectSize).maxCoeff() > 0.f;  // +x, +y or +z
    };
    const auto on_grown_face = [](const Eigen::Vector3f& local) {
      return test::face_normal(local, test::kTestObjectSize).y() < 0.f;
    };
    const ColoredCloud model_sampling = test::make_test_object(0.f, 0.005f);
    const ColoredCloud scene_sampling = test::make_test_object(0.5f, 0.005f);
    const auto add = [&](const ColoredCloud& from, auto&& on_face, ColoredCloud& to) {
      for (std::size_t k = 0; k < from.size(); ++k) {
        if (on_face(from.positions[k])) to.push_back(from.positions[k] + centre, from.colors[k]);
      }
    };
    add(model_sampling, on_plus_face, first_view);
    add(scene_sampling, on_plus_face, whole);
    grown_from = whole.size();
    add(scene_sampling, on_grown_face, whole);
    first_cluster.assign(first_view.size(), 0);
    whole_cluster.assign(whole.size(), 0);
    for (const Eigen::Vector3f& p : first_view.positions) centroid += p;
    centroid /= static_cast<float>(first_view.size());
  }
  // The mean distance of the model's grown part (object frame) from the -y face's nearest point, metres: how far the
  // face is turned off and away from its place (a slide along itself is not counted).
  float grown_error(const ManagedObject& object) const {
    float sum = 0.f;
    for (std::uint32_t k = object.part_ends[0]; k < object.part_ends[1]; ++k) {
      float nearest = 1.f;
      for (std::size_t i = grown_from; i < whole.size(); ++i) {
        nearest = std::min(nearest, (object.model.cloud.positions[k] - (whole.positions[i] - centroid)).norm());
      }
      sum += nearest;
    }
    return sum / static_cast<float>(object.part_ends[1] - object.part_ends[0]);
  }
};

TEST(ObjectManager, AGrownPartPlacedWithAWrongEstimateIsReFittedOnTheFirstView) {
  {
    const BoxGrownOff box;
    ObjectManagerOptions options;
    options.model_update.alpha = 0.f;  // the shipped setting: the thesis's update mixes the parts into one
    ObjectManager manager(options);
    manager.process(box.first_view, box.first_cluster, {});
    ASSERT_EQ(manager.objects().size(), 1u);
    const ManagedObject& object = manager.objects().at(1);
    EXPECT_EQ(object.part_ends, std::vector<std::uint32_t>{static_cast<std::uint32_t>(object.model.cloud.size())});
    const Pose right = object.pose;
    Pose off = right;
    off.rotation =
        Eigen::Quaternionf(Eigen::AngleAxisf(test::radians(3.f), Eigen::Vector3f(1.f, 0.f, 1.f).normalized()));
    // The -y face grows with the estimate 3 degrees off: a second part, the model thinned to its limit.
    manager.process(box.whole, box.whole_cluster, {{1, {off, 1.f}}});
    ASSERT_EQ(object.part_ends.size(), 2u);
    EXPECT_EQ(object.part_ends.back(), object.model.cloud.size());
    EXPECT_LT(object.model.cloud.size(), box.whole.size());
    EXPECT_GT(object.part_ends[1] - object.part_ends[0], 150u);
    const float before = box.grown_error(object);
    EXPECT_GT(before, 0.002f);
    const std::int32_t version = object.version;
    // The right estimate, both parts in view: the grown face is moved back, once.
    manager.process(box.whole, box.whole_cluster, {{1, {right, 1.f}}});
    EXPECT_EQ(object.version, version + 1);
    const float after = box.grown_error(object);
    std::printf("the grown face %.2f mm off before, %.2f mm after\n", 1e3f * before, 1e3f * after);
    // Both parts' point-to-point fits slide a little on faces sampled between the model's points (0.4 deg and
    // 0.7 mm for the first view here): about half of the error goes.
    EXPECT_LT(after, 0.6f * before);
    manager.process(box.whole, box.whole_cluster, {{1, {right, 1.f}}});
    EXPECT_EQ(object.version, version + 1);
  }
}

}  // namespace
}  // namespace mfot
