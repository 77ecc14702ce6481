// PartFinder: point sets of one scene split into parts side by side, the same for every thread count; and the
// ObjectManager running its births and confirmations through it (merger.threads).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <memory>
#include <stdexcept>
#include <vector>

#include "mfot/object_discovery.hpp"
#include "mfot/object_manager.hpp"
#include "mfot/part_finder.hpp"
#include "mfot/preprocessing.hpp"
#include "mfot/service/config.hpp"
#include "mfot/service/pipeline_config.hpp"
#include "mfot/sim/simulator.hpp"

namespace mfot {
namespace {

DiscoveryOptions lccp_options() {
  DiscoveryOptions options;
  options.method = DiscoveryMethod::kLccp;
  return options;
}

// The visible faces (top and the -y side, 5 mm samples) of an axis-aligned box [lo, hi] seen from above and in
// front, appended to scene with the indices of its points in `set`.
void add_box(ColoredCloud& scene, std::vector<int>& set, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi,
             Rgb8 color) {
  const float step = 0.005f;
  const Eigen::Matrix3f camera_from_world =
      Eigen::AngleAxisf(-2.2f, Eigen::Vector3f::UnitX()).toRotationMatrix();  // looking down at the table
  const auto add = [&](const Eigen::Vector3f& p) {
    set.push_back(static_cast<int>(scene.size()));
    scene.push_back(camera_from_world * p + Eigen::Vector3f(0.f, 0.f, 0.8f), color);
  };
  for (float x = lo.x() + step / 2; x < hi.x(); x += step) {
    for (float y = lo.y() + step / 2; y < hi.y(); y += step) add({x, y, hi.z()});
    for (float z = lo.z() + step / 2; z < hi.z(); z += step) add({x, lo.y(), z});
  }
}

// Three places on a table, each a tall box with a low one 2 cm beside it: a set per place (and an empty set).
struct Places {
  ColoredCloud scene;
  std::vector<std::vector<int>> sets;
};
Places three_places() {
  Places places;
  for (int k = 0; k < 3; ++k) {
    const float x = -0.3f + 0.3f * static_cast<float>(k);
    std::vector<int>& set = places.sets.emplace_back();
    add_box(places.scene, set, {x - 0.1f, -0.05f, 0.f}, {x, 0.05f, 0.12f}, Rgb8{200, 40, 40});
    add_box(places.scene, set, {x + 0.02f, -0.05f, 0.f}, {x + 0.12f, 0.05f, 0.05f}, Rgb8{40, 40, 200});
  }
  places.sets.emplace_back();  // an empty set has no parts
  return places;
}

TEST(PartFinder, SetsSplitSideBySideGiveTheSamePartsForEveryThreadCount) {
  const Places places = three_places();
  std::vector<std::vector<std::vector<int>>> one, three, alone;
  ThreadPool one_thread(1), three_threads(3);
  PartFinder single(make_object_discoveries(lccp_options(), 1), {}, 50, one_thread);
  PartFinder parallel(make_object_discoveries(lccp_options(), 3), {}, 50, three_threads);
  EXPECT_EQ(parallel.threads(), 3);
  single.find(places.scene, places.sets, one);
  parallel.find(places.scene, places.sets, three);
  EXPECT_EQ(one, three);
  ASSERT_EQ(one.size(), places.sets.size());
  for (std::size_t s = 0; s < 3; ++s) {
    EXPECT_EQ(one[s].size(), 2u) << "place " << s << ": the tall box and the low one";
    single.find(places.scene, std::span(&places.sets[s], 1), alone);  // a set on its own
    EXPECT_EQ(alone[0], one[s]) << "place " << s;
  }
  EXPECT_TRUE(one[3].empty());
}

TEST(PartFinder, RefusesWhatItCannotRun) {
  const Places places = three_places();
  std::vector<std::vector<std::vector<int>>> parts;
  ThreadPool pool(2);
  PartFinder none({}, {}, 50, pool);
  EXPECT_FALSE(none.enabled());
  EXPECT_THROW(none.find(places.scene, places.sets, parts), std::logic_error);
  std::vector<std::unique_ptr<ObjectDiscovery>> with_null;
  with_null.push_back(nullptr);
  EXPECT_THROW(PartFinder(std::move(with_null), {}, 50, pool), std::invalid_argument);
  EXPECT_THROW(PartFinder(make_object_discoveries(lccp_options(), 1), {}, 0, pool), std::invalid_argument);
  EXPECT_THROW(make_object_discoveries(lccp_options(), 0), std::invalid_argument);
  EXPECT_TRUE(make_object_discoveries(DiscoveryOptions{}, 4).empty());  // clusters: nothing to split
  PartFinder finder(make_object_discoveries(lccp_options(), 2), {}, 50, pool);
  const std::vector<std::vector<int>> outside{{0, 1, static_cast<int>(places.scene.size())}};
  EXPECT_THROW(finder.find(places.scene, outside, parts), std::out_of_range);
}

// The merger's births (first frame), confirmations (the frames after) and segmentation with 1 and 3 threads: the same
// labels and poses in every frame of procedural scenes with several clusters.
TEST(PartFinder, ObjectManagerGivesTheSameObjectsForEveryThreadCount) {
  const YAML::Node config = service::merged_over_defaults(YAML::Node());
  const auto merger = service::load_merger_config(config);
  ASSERT_GT(merger.manager.discovery.confirm_frames, 2);
  int births = 0, scenes = 0;
  for (std::uint64_t seed = 1; seed <= 30 && scenes < 2; ++seed) {
    sim::SimulatorOptions options;
    options.scenario.name = "procedural";
    options.scenario.seed = seed;
    const sim::Simulator simulator(options);
    if (simulator.summary().objects.size() < 4) continue;  // scenes of several clusters
    ++scenes;
    Preprocessor preprocessor(service::load_preprocess_config(config).preprocessor);
    ObjectManager one(merger.manager, make_object_discoveries(merger.manager.discovery, 1));
    ObjectManager three(merger.manager, make_object_discoveries(merger.manager.discovery, 3));
    for (int frame = 0; frame < 4; ++frame) {
      const SceneCloud& cloud = preprocessor.process(sim::image_view(simulator.render(frame)));
      ColoredCloud points;
      points.positions = cloud.positions;
      points.colors = cloud.colors;
      const std::vector<std::int32_t> labels = one.process(points, cloud.cluster, cloud.standing_clusters, {}).labels;
      EXPECT_EQ(three.process(points, cloud.cluster, cloud.standing_clusters, {}).labels, labels)
          << "seed " << seed << " frame " << frame;
      ASSERT_EQ(one.objects().size(), three.objects().size());
      for (const auto& [id, object] : one.objects()) {
        ASSERT_TRUE(three.objects().contains(id));
        EXPECT_EQ(object.pose.translation, three.objects().at(id).pose.translation);
        EXPECT_EQ(object.version, three.objects().at(id).version);
      }
    }
    births += static_cast<int>(one.objects().size());
  }
  EXPECT_EQ(scenes, 2);
  EXPECT_GE(births, 6);  // several objects, so several sets ran side by side
}

}  // namespace
}  // namespace mfot
