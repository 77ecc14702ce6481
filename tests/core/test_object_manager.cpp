#include "mfot/object_manager.hpp"

#include <gtest/gtest.h>

#include <map>

namespace mfot {
namespace {

// A solid block of points on a 5 mm lattice, coloured by its position so that models have texture.
void add_block(ColoredCloud& cloud, std::vector<std::int32_t>& cluster, std::int32_t cluster_id,
               const Eigen::Vector3f& min, const Eigen::Vector3i& cells) {
  for (int x = 0; x < cells.x(); ++x) {
    for (int y = 0; y < cells.y(); ++y) {
      for (int z = 0; z < cells.z(); ++z) {
        cloud.push_back(min + 0.005f * Eigen::Vector3f(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)),
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

  // Growth off: the same arm makes a second object once it persists.
  ObjectManagerOptions options;
  options.growth_frames = 0;
  options.new_objects.confirm_frames = 1;
  ObjectManager strict(options);
  ColoredCloud tip;
  std::vector<std::int32_t> tip_cluster;
  add_block(tip, tip_cluster, 0, {0.f, 0.f, 1.f}, {8, 8, 4});
  strict.process(tip, tip_cluster, {});
  strict.process(cloud, cluster, unchanged(strict));
  EXPECT_EQ(strict.objects().size(), 2u);
}

TEST(ObjectManager, RejectsInvalidOptionsAndInputs) {
  ObjectManagerOptions options;
  options.max_model_points = 10;
  options.min_object_points = 20;
  EXPECT_THROW(ObjectManager{options}, std::invalid_argument);
  ObjectManager manager;
  TwoBlocks scene;
  scene.cluster.pop_back();
  EXPECT_THROW(manager.process(scene.cloud, scene.cluster, {}), std::invalid_argument);
}

}  // namespace
}  // namespace mfot
