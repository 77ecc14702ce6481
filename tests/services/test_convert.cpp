#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "mfot/service/convert.hpp"
#include "mfot/service/merger_messages.hpp"
#include "mfot/smr_feature.hpp"

namespace mfot::service {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

Pose random_pose(std::mt19937_64& rng) {
  const auto uniform = [&rng] { return static_cast<float>(rng() >> 11) * 0x1.0p-53f * 2.0f - 1.0f; };
  Pose pose;
  pose.translation = Eigen::Vector3f(uniform(), uniform(), 0.5f + uniform());
  pose.rotation = Eigen::Quaternionf(uniform(), uniform(), uniform(), uniform() + 2.0f).normalized();
  return pose;
}

// An object model of n points with distinct positions and colours.
ObjectModel make_model(int n) {
  ObjectModel model;
  for (int i = 0; i < n; ++i) {
    model.cloud.push_back(Eigen::Vector3f(0.001f * i, -0.002f * i, 0.05f + 0.0005f * i),
                          Rgb8{static_cast<std::uint8_t>(i * 7), static_cast<std::uint8_t>(255 - i),
                               static_cast<std::uint8_t>(i * 13 + 5)});
  }
  model.features = compute_smr(model.cloud.colors);
  return model;
}

object_model_t over_the_wire(const object_model_t& message) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(message.getEncodedSize()));
  EXPECT_EQ(message.encode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  object_model_t decoded;
  EXPECT_EQ(decoded.decode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  return decoded;
}

// A scene message of n points in 2 clusters (every fourth point unclustered).
scene_cloud_t make_scene_message(int n) {
  scene_cloud_t msg{};
  msg.frame_seq = 42;
  msg.capture_utime = 1700000000123456;
  msg.width = 640;
  msg.height = 480;
  msg.voxel_size = 0.005f;
  msg.voxel_origin[0] = 0.001f;
  msg.voxel_origin[1] = 0.0025f;
  msg.voxel_origin[2] = 0.004f;
  msg.num_points = n;
  msg.num_clusters = 2;
  msg.num_standing_clusters = 1;
  for (int i = 0; i < n; ++i) {
    msg.x.push_back(0.01f * i);
    msg.y.push_back(-0.01f * i);
    msg.z.push_back(0.8f + 0.001f * i);
    msg.r.push_back(static_cast<std::int8_t>(i));
    msg.g.push_back(static_cast<std::int8_t>(200));  // above 127: the byte's sign must not leak
    msg.b.push_back(static_cast<std::int8_t>(3 * i));
    msg.u.push_back(static_cast<std::int16_t>(i));
    msg.v.push_back(static_cast<std::int16_t>(2 * i));
    msg.cluster.push_back(i % 4 == 3 ? -1 : i % 2);
  }
  return msg;
}

TEST(Convert, PoseRoundTripsThroughArrays) {
  std::mt19937_64 rng(7);
  for (int k = 0; k < 50; ++k) {
    const Pose pose = random_pose(rng);
    double position[3], orientation[4];
    pose_to_arrays(pose, position, orientation);
    Pose back;
    ASSERT_FALSE(pose_from_arrays(position, orientation, back).has_value());
    EXPECT_TRUE(back.translation.isApprox(pose.translation, 1e-6f));
    EXPECT_NEAR(std::abs(back.rotation.dot(pose.rotation)), 1.0f, 1e-6f);
  }
}

TEST(Convert, PoseFromArraysNormalisesNearlyUnitQuaternionsAndRejectsOthers) {
  const double position[3] = {0.1, 0.2, 0.3};
  Pose pose;
  const double nearly_unit[4] = {1.0004, 0.0, 0.0, 0.0};
  ASSERT_FALSE(pose_from_arrays(position, nearly_unit, pose).has_value());
  EXPECT_NEAR(pose.rotation.norm(), 1.0f, 1e-6f);

  for (const auto& q : {std::array<double, 4>{0.5, 0.0, 0.0, 0.0}, std::array<double, 4>{0.0, 0.0, 0.0, 0.0},
                        std::array<double, 4>{kNaN, 0.0, 0.0, 1.0}, std::array<double, 4>{1.0, kInf, 0.0, 0.0}}) {
    EXPECT_TRUE(pose_from_arrays(position, q.data(), pose).has_value()) << q[0] << " " << q[1];
  }
  const double unit[4] = {1.0, 0.0, 0.0, 0.0};
  for (const auto& p : {std::array<double, 3>{kNaN, 0.0, 0.0}, std::array<double, 3>{0.0, -kInf, 0.0}}) {
    EXPECT_TRUE(pose_from_arrays(p.data(), unit, pose).has_value());
  }
}

TEST(Convert, ModelRoundTripsThroughTheMessageAndTheWire) {
  const ObjectModel model = make_model(37);
  std::mt19937_64 rng(11);
  const Pose pose = random_pose(rng);
  object_model_t msg{};
  msg.object_id = 3;
  model_to_message(model, msg);
  pose_to_arrays(pose, msg.position, msg.orientation);
  for (int i = 0; i < 6; ++i) msg.velocity[i] = 0.01 * (i + 1);
  EXPECT_EQ(msg.num_points, 37);

  ObjectModel back;
  Pose back_pose;
  PoseVector velocity;
  ASSERT_FALSE(model_from_message(over_the_wire(msg), back, back_pose, velocity).has_value());
  ASSERT_EQ(back.cloud.size(), model.cloud.size());
  for (std::size_t i = 0; i < model.cloud.size(); ++i) {
    EXPECT_EQ(back.cloud.positions[i], model.cloud.positions[i]) << i;
    EXPECT_EQ(back.cloud.colors[i], model.cloud.colors[i]) << i;
  }
  // Features are recomputed from the colours on arrival.
  const auto expected = compute_smr(model.cloud.colors);
  ASSERT_EQ(back.features.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(back.features[i].hue_bin, expected[i].hue_bin) << i;
    EXPECT_EQ(back.features[i].gray_bin, expected[i].gray_bin) << i;
    EXPECT_EQ(back.features[i].hue_weight_lo, expected[i].hue_weight_lo) << i;
    EXPECT_EQ(back.features[i].hue_weight_hi, expected[i].hue_weight_hi) << i;
    EXPECT_EQ(back.features[i].gray_weight, expected[i].gray_weight) << i;
  }
  EXPECT_TRUE(back_pose.translation.isApprox(pose.translation, 1e-6f));
  for (int i = 0; i < 6; ++i) EXPECT_FLOAT_EQ(velocity[i], 0.01f * (i + 1));
}

TEST(Convert, ClaimedPointsRoundTripAndBadOnesAreNamed) {
  const std::vector<Eigen::Vector3f> claimed{{0.1f, -0.2f, 1.1f}, {0.f, 0.f, 0.5f}};
  object_model_t msg{};
  model_to_message(make_model(3), msg);
  claimed_to_message(claimed, msg);
  EXPECT_EQ(msg.num_claimed, 2);
  std::vector<Eigen::Vector3f> back{{9.f, 9.f, 9.f}};
  ASSERT_FALSE(claimed_from_message(over_the_wire(msg), back).has_value());
  EXPECT_EQ(back, claimed);
  object_model_t none{};
  ASSERT_FALSE(claimed_from_message(over_the_wire(none), back).has_value());
  EXPECT_TRUE(back.empty());

  object_model_t nan_point = msg;
  nan_point.claimed_y[1] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(claimed_from_message(nan_point, back), "non-finite claimed point 1");
  EXPECT_TRUE(back.empty());
  object_model_t short_array = msg;
  short_array.claimed_z.pop_back();
  EXPECT_EQ(claimed_from_message(short_array, back), "claimed array sizes disagree with num_claimed");
  object_model_t negative = msg;
  negative.num_claimed = -1;
  EXPECT_EQ(claimed_from_message(negative, back), "negative num_claimed");
}

TEST(Convert, EmptyModelRoundTrips) {
  object_model_t msg{};
  msg.orientation[0] = 1.0;
  model_to_message(ObjectModel{}, msg);
  ObjectModel back = make_model(3);
  Pose pose;
  PoseVector velocity;
  ASSERT_FALSE(model_from_message(over_the_wire(msg), back, pose, velocity).has_value());
  EXPECT_TRUE(back.cloud.empty());
  EXPECT_TRUE(back.features.empty());
}

TEST(Convert, InvalidModelsAreRejectedWithTheReason) {
  object_model_t valid{};
  model_to_message(make_model(5), valid);
  valid.orientation[0] = 1.0;
  ObjectModel model;
  Pose pose;
  PoseVector velocity;
  ASSERT_FALSE(model_from_message(valid, model, pose, velocity).has_value());

  auto negative = valid;
  negative.num_points = -1;
  EXPECT_EQ(model_from_message(negative, model, pose, velocity), "negative num_points");
  auto short_array = valid;
  short_array.g.pop_back();
  EXPECT_EQ(model_from_message(short_array, model, pose, velocity), "array sizes disagree with num_points");
  auto nan_point = valid;
  nan_point.y[2] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(model_from_message(nan_point, model, pose, velocity), "non-finite model point 2");
  auto inf_velocity = valid;
  inf_velocity.velocity[4] = kInf;
  EXPECT_EQ(model_from_message(inf_velocity, model, pose, velocity), "non-finite velocity");
  auto bad_orientation = valid;
  bad_orientation.orientation[0] = 2.0;
  EXPECT_EQ(model_from_message(bad_orientation, model, pose, velocity), "orientation is not a unit quaternion");
  auto negative_carrier = valid;
  negative_carrier.carried_by = -3;
  EXPECT_EQ(model_from_message(negative_carrier, model, pose, velocity), "negative carried_by");
  auto self_carried = valid;
  self_carried.object_id = 4;
  self_carried.carried_by = 4;
  EXPECT_EQ(model_from_message(self_carried, model, pose, velocity), "an object carried by itself");
  auto carried = self_carried;
  carried.carried_by = 2;
  EXPECT_FALSE(model_from_message(carried, model, pose, velocity).has_value());

  // The companion's motion: none, a valid one, and what is wrong with the others.
  std::optional<PoseVector> companion = PoseVector::Zero();
  EXPECT_FALSE(companion_from_message(valid, companion).has_value());
  EXPECT_FALSE(companion.has_value());
  auto with_companion = self_carried;  // object 4
  with_companion.companion = 2;
  for (int i = 0; i < 6; ++i) with_companion.companion_motion[i] = 0.01 * (i + 1);
  EXPECT_FALSE(companion_from_message(with_companion, companion).has_value());
  ASSERT_TRUE(companion.has_value());
  EXPECT_FLOAT_EQ((*companion)[5], 0.06f);
  auto negative_companion = with_companion;
  negative_companion.companion = -1;
  EXPECT_EQ(companion_from_message(negative_companion, companion), "negative companion");
  EXPECT_FALSE(companion.has_value());
  auto own_companion = with_companion;
  own_companion.companion = 4;
  EXPECT_EQ(companion_from_message(own_companion, companion), "an object that is its own companion");
  auto nan_motion = with_companion;
  nan_motion.companion_motion[3] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(companion_from_message(nan_motion, companion), "non-finite companion_motion");
}

// What the merger sends with a model reaches the tracker: the pose, carried_by and the companion's motion.
TEST(Convert, AModelMessageCarriesTheCompanionsMotion) {
  ManagedObject object;
  object.id = 5;
  object.model.cloud.push_back({0.01f, 0.f, 0.f}, {10, 20, 30});
  object.pose.translation = {0.1f, -0.2f, 0.9f};
  object.companion = 2;
  object.companion_motion << 0.004f, -0.001f, 0.f, 0.01f, 0.02f, -0.03f;
  const object_model_t msg = model_message(object, 1, 77, 12, {}, 1000);
  EXPECT_EQ(msg.companion, 2);
  std::optional<PoseVector> motion;
  ASSERT_FALSE(companion_from_message(msg, motion).has_value());
  ASSERT_TRUE(motion.has_value());
  EXPECT_LT((*motion - object.companion_motion).norm(), 1e-7f);
  object.companion = 0;
  ASSERT_FALSE(companion_from_message(model_message(object, 1, 77, 12, {}, 1000), motion).has_value());
  EXPECT_FALSE(motion.has_value());
}

TEST(Convert, SceneMessageBecomesTheSceneItDescribes) {
  const scene_cloud_t msg = make_scene_message(9);
  Scene scene;
  ASSERT_FALSE(scene_from_message(msg, scene).has_value());
  EXPECT_EQ(scene.frame_seq, 42);
  EXPECT_EQ(scene.capture_utime, 1700000000123456);
  EXPECT_EQ(scene.voxel_grid.leaf, 0.005f);
  EXPECT_EQ(scene.voxel_grid.corner, Eigen::Vector3f(0.001f, 0.0025f, 0.004f));
  ASSERT_EQ(scene.cloud.size(), 9u);
  ASSERT_EQ(scene.cluster.size(), 9u);
  for (std::size_t i = 0; i < 9; ++i) {
    EXPECT_EQ(scene.cloud.positions[i], Eigen::Vector3f(msg.x[i], msg.y[i], msg.z[i]));
    EXPECT_EQ(scene.cloud.colors[i].r, static_cast<std::uint8_t>(i));
    EXPECT_EQ(scene.cloud.colors[i].g, 200);
    EXPECT_EQ(scene.cloud.colors[i].b, static_cast<std::uint8_t>(3 * i));
    EXPECT_EQ(scene.cluster[i], msg.cluster[i]);
  }
  EXPECT_FALSE(scene.view.has_value());  // no intrinsics given
  scene_cloud_t with_intrinsics = msg;
  with_intrinsics.fx = with_intrinsics.fy = 500.f;
  with_intrinsics.cx = 319.5f;
  with_intrinsics.cy = 239.5f;
  ASSERT_FALSE(scene_from_message(with_intrinsics, scene).has_value());
  ASSERT_TRUE(scene.view.has_value());
  EXPECT_FLOAT_EQ(scene.view->x_max, 320.f / 500.f);
  EXPECT_FLOAT_EQ(scene.view->y_min, -240.f / 500.f);
}

TEST(Convert, InvalidScenesAreRejectedWithTheReason) {
  const scene_cloud_t valid = make_scene_message(6);
  Scene scene;
  auto negative = valid;
  negative.num_points = -3;
  EXPECT_EQ(scene_from_message(negative, scene), "negative num_points");
  auto long_array = valid;
  long_array.cluster.push_back(0);
  EXPECT_EQ(scene_from_message(long_array, scene), "array sizes disagree with num_points");
  for (const float voxel :
       {0.0f, -0.005f, std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
    auto bad_voxel = valid;
    bad_voxel.voxel_size = voxel;
    EXPECT_EQ(scene_from_message(bad_voxel, scene), "voxel_size must be finite and > 0") << voxel;
  }
  auto bad_origin = valid;
  bad_origin.voxel_origin[1] = std::numeric_limits<float>::infinity();
  EXPECT_EQ(scene_from_message(bad_origin, scene), "voxel_origin must be finite");
  for (const float fy : {-500.f, 0.f, std::numeric_limits<float>::quiet_NaN()}) {
    auto bad_intrinsics = valid;
    bad_intrinsics.fx = 500.f;
    bad_intrinsics.fy = fy;
    EXPECT_EQ(scene_from_message(bad_intrinsics, scene), "intrinsics must be finite with fx, fy > 0") << fy;
  }
  auto negative_size = valid;
  negative_size.fx = negative_size.fy = 500.f;
  negative_size.width = -640;
  EXPECT_EQ(scene_from_message(negative_size, scene), "negative image size");
  auto inf_point = valid;
  inf_point.z[4] = -std::numeric_limits<float>::infinity();
  EXPECT_EQ(scene_from_message(inf_point, scene), "non-finite coordinate at point 4");
  auto cluster_too_large = valid;
  cluster_too_large.cluster[1] = valid.num_clusters;
  EXPECT_TRUE(scene_from_message(cluster_too_large, scene).has_value());
  auto cluster_below_none = valid;
  cluster_below_none.cluster[0] = -2;
  EXPECT_TRUE(scene_from_message(cluster_below_none, scene).has_value());
  for (const std::int32_t standing : {-1, 3}) {
    auto bad_standing = valid;
    bad_standing.num_standing_clusters = standing;
    EXPECT_EQ(scene_from_message(bad_standing, scene),
              "num_standing_clusters " + std::to_string(standing) + " outside [0, num_clusters 2]");
  }
  ASSERT_FALSE(scene_from_message(valid, scene).has_value());
  EXPECT_EQ(scene.cloud.size(), 6u);
}

TEST(Convert, APreprocessedSceneTravelsWithItsFramesIdentityAndComesBackTheSame) {
  SceneCloud cloud;
  for (int i = 0; i < 5; ++i) {
    cloud.positions.emplace_back(0.01f * static_cast<float>(i), -0.02f, 0.9f + 0.001f * static_cast<float>(i));
    cloud.colors.push_back(Rgb8{static_cast<std::uint8_t>(40 * i), 7, 9});
    cloud.pixel_u.push_back(static_cast<std::int16_t>(100 + i));
    cloud.pixel_v.push_back(static_cast<std::int16_t>(50 + i));
    cloud.cluster.push_back(i < 3 ? 0 : -1);
  }
  cloud.num_clusters = 2;
  cloud.standing_clusters = 1;
  cloud.cluster[4] = 1;  // a cluster off the table
  cloud.plane.valid = true;
  cloud.plane.coefficients = Eigen::Vector4f(0.f, -1.f, 0.f, 0.8f);
  cloud.voxel_grid = VoxelGrid{.leaf = 0.005f, .corner = Eigen::Vector3f(0.003f, 0.f, 0.0015f)};
  frame_t source{};
  source.seq = 17;
  source.capture_utime = 123456;
  source.width = 640;
  source.height = 480;
  source.fx = source.fy = 570.f;
  source.cx = 319.5f;
  source.cy = 239.5f;
  scene_cloud_t msg{};
  msg.x.assign(100, 1.f);  // a reused message's old contents must go
  scene_to_message(cloud, source, msg);
  EXPECT_EQ(msg.frame_seq, 17);
  EXPECT_EQ(msg.width, 640);
  EXPECT_EQ(msg.fx, 570.f);
  EXPECT_EQ(msg.plane[1], -1.f);
  EXPECT_EQ(msg.u, cloud.pixel_u);
  EXPECT_EQ(msg.v, cloud.pixel_v);
  Scene scene;
  ASSERT_FALSE(scene_from_message(msg, scene).has_value());
  EXPECT_EQ(scene.frame_seq, 17);
  EXPECT_EQ(scene.capture_utime, 123456);
  EXPECT_EQ(scene.voxel_grid.leaf, 0.005f);
  EXPECT_EQ(scene.voxel_grid.corner, cloud.voxel_grid.corner);
  EXPECT_EQ(scene.cloud.positions, cloud.positions);
  EXPECT_EQ(scene.cluster, std::vector<std::int32_t>(cloud.cluster.begin(), cloud.cluster.end()));
  EXPECT_EQ(scene.standing_clusters, 1);
  for (std::size_t i = 0; i < 5; ++i) EXPECT_EQ(scene.cloud.colors[i].r, cloud.colors[i].r);
  ASSERT_TRUE(scene.view.has_value());

  // In process (InprocessPipeline, BaselinePipeline): the same scene without the wire, into a reused one.
  const Frame decoded{.capture_utime = source.capture_utime,
                      .width = source.width,
                      .height = source.height,
                      .fx = source.fx,
                      .fy = source.fy,
                      .cx = source.cx,
                      .cy = source.cy,
                      .depth_mm = {},
                      .color = {}};
  Scene direct;
  direct.cloud.positions.assign(9, Eigen::Vector3f::Ones());  // a reused scene's old contents must go
  scene_from_cloud(cloud, decoded, source.seq, direct);
  EXPECT_EQ(direct.frame_seq, scene.frame_seq);
  EXPECT_EQ(direct.capture_utime, scene.capture_utime);
  EXPECT_EQ(direct.voxel_grid.leaf, scene.voxel_grid.leaf);
  EXPECT_EQ(direct.voxel_grid.corner, scene.voxel_grid.corner);
  EXPECT_EQ(direct.cloud.positions, scene.cloud.positions);
  EXPECT_EQ(direct.cluster, scene.cluster);
  EXPECT_EQ(direct.standing_clusters, scene.standing_clusters);
  for (std::size_t i = 0; i < 5; ++i) EXPECT_EQ(direct.cloud.colors[i].g, scene.cloud.colors[i].g);
  ASSERT_TRUE(direct.view.has_value());
  EXPECT_EQ(direct.view->x_min, scene.view->x_min);
  EXPECT_EQ(direct.view->y_max, scene.view->y_max);
}

}  // namespace
}  // namespace mfot::service
