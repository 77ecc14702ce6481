// Decodable but hostile messages: values that pass the wire format but would make a receiver
// allocate without bound. The converters refuse them with the reason, before the core sees them.

#include <gtest/gtest.h>

#include <limits>

#include "mfot/service/convert.hpp"

namespace mfot::service {
namespace {

scene_cloud_t scene_message(int n) {
  scene_cloud_t msg{};
  msg.voxel_size = 0.005f;
  msg.num_points = n;
  msg.num_clusters = 1;
  msg.num_standing_clusters = 1;
  for (int i = 0; i < n; ++i) {
    msg.x.push_back(0.01f * static_cast<float>(i));
    msg.y.push_back(0.f);
    msg.z.push_back(1.f);
    msg.r.push_back(10);
    msg.g.push_back(20);
    msg.b.push_back(30);
    msg.u.push_back(static_cast<std::int16_t>(i));
    msg.v.push_back(0);
    msg.cluster.push_back(0);
  }
  return msg;
}

object_model_t model_message(int n) {
  object_model_t msg{};
  msg.object_id = 1;
  msg.num_points = n;
  msg.orientation[0] = 1.0;
  for (int i = 0; i < n; ++i) {
    msg.x.push_back(0.01f * static_cast<float>(i));
    msg.y.push_back(0.f);
    msg.z.push_back(0.f);
    msg.r.push_back(200);
    msg.g.push_back(0);
    msg.b.push_back(0);
  }
  return msg;
}

TEST(EdgeMessages, ClusterIndexBeyondThePointCountIsRefused) {
  // One point in cluster 2^31 - 2 would have the merger size a table of 2^31 clusters.
  scene_cloud_t msg = scene_message(3);
  msg.num_clusters = std::numeric_limits<std::int32_t>::max();
  msg.cluster[2] = std::numeric_limits<std::int32_t>::max() - 1;
  Scene scene;
  EXPECT_EQ(scene_from_message(msg, scene), "cluster index 2147483646 out of range at point 2");
  msg.cluster[2] = 3;  // below num_clusters, but 3 points cannot make 4 clusters
  EXPECT_EQ(scene_from_message(msg, scene), "cluster index 3 out of range at point 2");
  const scene_cloud_t valid = scene_message(3);
  EXPECT_EQ(scene_from_message(valid, scene), std::nullopt);
}

TEST(EdgeMessages, ModelPointsFarFromTheObjectOriginAreRefused) {
  // Two points 2 km apart would ask the tracker for a JCSD grid of 10^15 corners.
  object_model_t msg = model_message(4);
  msg.x[3] = 2000.f;
  ObjectModel model;
  Pose pose;
  PoseVector velocity;
  const auto error = model_from_message(msg, model, pose, velocity);
  ASSERT_TRUE(error.has_value());
  EXPECT_NE(error->find("model point 3"), std::string::npos) << *error;
  msg.x[3] = -kMaxModelRadius * 1.01f;
  EXPECT_TRUE(model_from_message(msg, model, pose, velocity).has_value());
  msg.x[3] = kMaxModelRadius;
  EXPECT_EQ(model_from_message(msg, model, pose, velocity), std::nullopt);
  EXPECT_EQ(model.cloud.size(), 4u);
}

}  // namespace
}  // namespace mfot::service
