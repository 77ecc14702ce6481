// Edge-case scenes through the whole core pipeline as the services run it (Preprocessor -> one
// ParticleFilter + CPU JCSD likelihood per object -> ObjectManager): nothing in view, a single
// measured pixel, non-finite input, an object leaving the view, and twenty objects at once.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <set>

#include "expect_invalid_argument.hpp"
#include "mfot/estimate_fit.hpp"
#include "mfot/hypothesis.hpp"
#include "mfot/jcsd_likelihood.hpp"
#include "mfot/object_manager.hpp"
#include "mfot/particle_filter.hpp"
#include "mfot/preprocessing.hpp"
#include "mfot/smr_feature.hpp"
#include "preprocess_test_scene.hpp"

namespace mfot {
namespace {

bool finite(const Pose& pose) {
  return pose.translation.allFinite() && pose.rotation.coeffs().allFinite() &&
         std::abs(pose.rotation.norm() - 1.f) < 1e-3f;
}

// The per-frame loop of mfot-inprocess (services/inprocess/main.cpp) on core types only.
class CorePipeline {
 public:
  CorePipeline() {
    filter_options_.num_particles = 100;  // the shipped configs/default.yaml value
  }

  const ObjectManagerFrame& step(const RgbdImageView& view) {
    const SceneCloud& cloud = preprocessor_.process(view);
    scene_.positions = cloud.positions;
    scene_.colors = cloud.colors;
    clusters_.assign(cloud.cluster.begin(), cloud.cluster.end());
    features_ = compute_smr(scene_.colors);
    std::map<std::int32_t, ObjectEstimate> estimates;
    for (auto& [id, tracker] : trackers_) {
      select_hypothesis_data(scene_, features_, tracker.box, tracker.filter->estimate(), HypothesisOptions{},
                             hypothesis_);
      const Pose& estimate = tracker.filter->step(hypothesis_, *tracker.likelihood);
      estimates[id] = {estimate, fit_.fit(hypothesis_, manager_.objects().at(id).model, tracker.box, estimate)};
    }
    const ObjectManagerFrame& result = manager_.process(scene_, clusters_, estimates);
    for (const std::int32_t id : result.retired) trackers_.erase(id);
    for (const auto& [id, object] : manager_.objects()) {
      auto [it, created] = trackers_.try_emplace(id);
      if (created) {
        it->second.likelihood = std::make_unique<JcsdLikelihood>();
        ParticleFilterOptions options = filter_options_;
        options.seed += static_cast<std::uint64_t>(id);
        it->second.filter = std::make_unique<ParticleFilter>(options);
        it->second.filter->reset(object.pose);
      }
      it->second.box = model_bounding_box(object.model);
      it->second.likelihood->set_model(object.model);
    }
    return result;
  }

  const ObjectManager& manager() const { return manager_; }
  const ColoredCloud& scene() const { return scene_; }

 private:
  struct Tracker {
    std::unique_ptr<JcsdLikelihood> likelihood;
    std::unique_ptr<ParticleFilter> filter;
    Eigen::AlignedBox3f box;
  };
  ParticleFilterOptions filter_options_;
  Preprocessor preprocessor_;
  ObjectManager manager_;
  std::map<std::int32_t, Tracker> trackers_;
  ColoredCloud scene_;
  std::vector<std::int32_t> clusters_;
  std::vector<SmrFeature> features_;
  HypothesisData hypothesis_;
  EstimateFit fit_;
};

test_scene::Frame empty_frame(int width = 640, int height = 480) {
  test_scene::Frame frame;
  frame.width = width;
  frame.height = height;
  frame.depth_mm.assign(static_cast<std::size_t>(width * height), 0);
  frame.color.assign(frame.depth_mm.size(), Rgb8{});
  return frame;
}

// A 5 cm cube standing on the table at world (x, y).
test_scene::Box cube_at(float x, float y, Rgb8 color) {
  return test_scene::Box{{x - 0.025f, y - 0.025f, 0.f}, {x + 0.025f, y + 0.025f, 0.05f}, color};
}

TEST(EdgeScenes, NoMeasurementAtAllCreatesNothing) {
  CorePipeline pipeline;
  const test_scene::Frame frame = empty_frame();
  for (int i = 0; i < 5; ++i) {
    const ObjectManagerFrame& result = pipeline.step(frame.view());
    EXPECT_TRUE(result.labels.empty());
    EXPECT_TRUE(result.created.empty());
  }
  EXPECT_TRUE(pipeline.manager().objects().empty());
}

TEST(EdgeScenes, EmptyTableCreatesNothing) {
  CorePipeline pipeline;
  test_scene::Camera camera;
  camera.depth_noise_mm = 1.f;
  const test_scene::Frame frame = test_scene::render(test_scene::Scene{}, camera);
  for (int i = 0; i < 8; ++i) {
    const ObjectManagerFrame& result = pipeline.step(frame.view());
    EXPECT_TRUE(result.created.empty()) << "frame " << i;
  }
  EXPECT_TRUE(pipeline.manager().objects().empty());
}

TEST(EdgeScenes, OneMeasuredPixelCreatesNothing) {
  CorePipeline pipeline;
  test_scene::Frame frame = empty_frame();
  frame.depth_mm[240 * 640 + 320] = 800;
  frame.color[240 * 640 + 320] = Rgb8{255, 0, 0};
  for (int i = 0; i < 5; ++i) {
    const ObjectManagerFrame& result = pipeline.step(frame.view());
    EXPECT_LE(pipeline.scene().size(), 1u);
    EXPECT_TRUE(result.created.empty());
  }
  EXPECT_TRUE(pipeline.manager().objects().empty());
}

TEST(EdgeScenes, NonFiniteScenePointsAreRefusedByTheManager) {
  // The services drop such scenes at the wire (scene_from_message); the manager refuses them too
  // instead of making an object with a NaN pose out of them.
  ObjectManager manager;
  ColoredCloud scene;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int i = 0; i < 200; ++i) scene.push_back(Eigen::Vector3f(nan, nan, nan), Rgb8{255, 0, 0});
  const std::vector<std::int32_t> one_cluster(scene.size(), 0);
  test::expect_invalid_argument([&] { manager.process(scene, one_cluster, {}); }, "non-finite");
  EXPECT_TRUE(manager.objects().empty());
}

TEST(EdgeScenes, ClusterIndexBeyondThePointsIsRefusedByTheManager) {
  ObjectManager manager;
  ColoredCloud scene;
  for (int i = 0; i < 60; ++i) scene.push_back(Eigen::Vector3f(0.001f * static_cast<float>(i), 0.f, 1.f), Rgb8{});
  std::vector<std::int32_t> clusters(scene.size(), 0);
  clusters[7] = std::numeric_limits<std::int32_t>::max() - 1;  // would size a table of 2^31 clusters
  EXPECT_THROW(manager.process(scene, clusters, {}), std::invalid_argument);
  clusters[7] = -2;
  EXPECT_THROW(manager.process(scene, clusters, {}), std::invalid_argument);
  clusters[7] = 0;
  EXPECT_NO_THROW(manager.process(scene, clusters, {}));
  EXPECT_EQ(manager.objects().size(), 1u);
}

TEST(EdgeScenes, ModelTooLargeForAJcsdGridIsRefused) {
  ObjectModel model;
  model.cloud.push_back(Eigen::Vector3f::Zero(), Rgb8{255, 0, 0});
  model.cloud.push_back(Eigen::Vector3f(1000.f, 1000.f, 1000.f), Rgb8{255, 0, 0});
  model.features = compute_smr(model.cloud.colors);
  JcsdLikelihood likelihood;
  EXPECT_THROW(likelihood.set_model(model), std::invalid_argument);
  model.cloud.positions[1] = Eigen::Vector3f(0.1f, 0.1f, 0.1f);
  EXPECT_NO_THROW(likelihood.set_model(model));
}

TEST(EdgeScenes, NonFiniteEstimateLeavesTheObjectStaleWithItsLastPose) {
  CorePipeline pipeline;  // for a preprocessed scene with one cube
  test_scene::Scene scene;
  scene.boxes.push_back(cube_at(0.f, 0.f, Rgb8{200, 30, 30}));
  pipeline.step(test_scene::render(scene, test_scene::Camera{}).view());
  ASSERT_GT(pipeline.scene().size(), 50u);

  // A broken tracker's estimate: the manager keeps the last pose and marks the object stale.
  ObjectManager manager;
  const std::vector<std::int32_t> clusters(pipeline.scene().size(), 0);
  manager.process(pipeline.scene(), clusters, {});
  ASSERT_EQ(manager.objects().size(), 1u);
  const std::int32_t id = manager.objects().begin()->first;
  const Pose first = manager.objects().begin()->second.pose;
  ASSERT_TRUE(finite(first));
  ObjectEstimate bad;
  bad.pose.translation = Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
  bad.confidence = 0.5f;
  manager.process(pipeline.scene(), clusters, {{id, bad}});
  const ManagedObject& after = manager.objects().at(id);
  EXPECT_TRUE(after.stale);
  EXPECT_TRUE(finite(after.pose));
  EXPECT_TRUE(after.pose.translation.isApprox(first.translation));
  EXPECT_TRUE(after.velocity.allFinite());
  EXPECT_EQ(manager.last_frame().labels.size(), pipeline.scene().size());
}

TEST(EdgeScenes, ObjectLeavingTheViewIsRetiredWithoutNaNPoses) {
  CorePipeline pipeline;
  const test_scene::Camera camera;
  test_scene::Scene scene;
  scene.boxes.push_back(cube_at(0.f, 0.f, Rgb8{30, 180, 40}));    // stays
  scene.boxes.push_back(cube_at(0.30f, 0.f, Rgb8{200, 30, 30}));  // slides out of the view (+x)
  const float step_m = 0.015f;
  int left_view_at = -1;  // first frame the moving cube has no pixel in the image
  std::int32_t moving_id = 0;
  int retired_at = -1;
  for (int frame_index = 0; frame_index < 80 && retired_at < 0; ++frame_index) {
    scene.boxes[1] = cube_at(0.30f + step_m * static_cast<float>(frame_index), 0.f, Rgb8{200, 30, 30});
    const test_scene::Frame frame = test_scene::render(scene, camera);
    bool moving_visible = false;
    for (std::size_t i = 0; i < frame.color.size() && !moving_visible; ++i) {
      moving_visible = frame.depth_mm[i] > 0 && frame.color[i].r == 200;
    }
    if (!moving_visible && left_view_at < 0) left_view_at = frame_index;
    const ObjectManagerFrame& result = pipeline.step(frame.view());
    if (frame_index == 0) {
      ASSERT_EQ(result.created.size(), 2u);
      // Ids are numbered by cluster order; the moving cube is the one further along +x in the image.
      const auto& objects = pipeline.manager().objects();
      moving_id = objects.at(1).pose.translation.x() > objects.at(2).pose.translation.x() ? 1 : 2;
    } else {
      EXPECT_TRUE(result.created.empty()) << "an object made from nothing at frame " << frame_index;
    }
    for (const auto& [id, object] : pipeline.manager().objects()) {
      ASSERT_TRUE(finite(object.pose)) << "object " << id << " frame " << frame_index;
      ASSERT_TRUE(object.velocity.allFinite()) << "object " << id << " frame " << frame_index;
    }
    for (const std::int32_t id : result.retired) {
      EXPECT_EQ(id, moving_id) << "the static cube was retired at frame " << frame_index;
      retired_at = frame_index;
    }
  }
  ASSERT_GE(left_view_at, 0) << "the cube never left the view";
  ASSERT_GE(retired_at, 0) << "the cube that left the view was never retired";
  // Retired at most support.max_frames (5) frames after it lost its last pixel; it may go
  // earlier, while only a sliver of it is left at the image border.
  EXPECT_LE(retired_at, left_view_at + 5);
  ASSERT_EQ(pipeline.manager().objects().size(), 1u);
  EXPECT_EQ(pipeline.manager().objects().begin()->first, 3 - moving_id);
}

TEST(EdgeScenes, TwentyObjectsAreTrackedWithDistinctIds) {
  CorePipeline pipeline;
  test_scene::Scene scene;
  const Rgb8 palette[5] = {{200, 30, 30}, {30, 180, 40}, {30, 60, 200}, {220, 200, 40}, {180, 40, 180}};
  for (int row = 0; row < 4; ++row) {
    for (int col = 0; col < 5; ++col) {
      const float x = -0.24f + 0.12f * static_cast<float>(col);
      const float y = -0.18f + 0.12f * static_cast<float>(row);
      scene.boxes.push_back(cube_at(x, y, palette[(row + col) % 5]));
    }
  }
  test_scene::Camera camera;
  camera.depth_noise_mm = 1.f;
  std::map<std::int32_t, Eigen::Vector3f> first_position;
  for (int frame_index = 0; frame_index < 6; ++frame_index) {
    camera.noise_seed = static_cast<std::uint64_t>(frame_index + 1);
    const test_scene::Frame frame = test_scene::render(scene, camera);
    const ObjectManagerFrame& result = pipeline.step(frame.view());
    if (frame_index == 0) {
      EXPECT_EQ(result.created.size(), 20u);
      for (const auto& [id, object] : pipeline.manager().objects()) first_position[id] = object.pose.translation;
    } else {
      EXPECT_TRUE(result.created.empty()) << "frame " << frame_index;
      EXPECT_TRUE(result.retired.empty()) << "frame " << frame_index;
    }
  }
  const auto& objects = pipeline.manager().objects();
  ASSERT_EQ(objects.size(), 20u);
  std::set<std::int32_t> ids;
  std::set<std::int32_t> labelled;
  for (const std::int32_t label : pipeline.manager().last_frame().labels) labelled.insert(label);
  for (const auto& [id, object] : objects) {
    ids.insert(id);
    EXPECT_FALSE(object.stale);
    EXPECT_TRUE(finite(object.pose));
    EXPECT_GT(object.support, 50u) << "object " << id;
    EXPECT_TRUE(labelled.count(id)) << "object " << id << " labels no scene point";
    // The scene is static: the tracked position stays where the object was found.
    EXPECT_LT((object.pose.translation - first_position.at(id)).norm(), 0.006f) << "object " << id;
  }
  EXPECT_EQ(ids.size(), 20u);
  // No two objects were found at the same place.
  for (auto a = first_position.begin(); a != first_position.end(); ++a) {
    for (auto b = std::next(a); b != first_position.end(); ++b) {
      EXPECT_GT((a->second - b->second).norm(), 0.06f) << a->first << " and " << b->first;
    }
  }
}

}  // namespace
}  // namespace mfot
