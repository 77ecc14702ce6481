// LCCP discovery (mfot_discovery) on synthetic table-top views: boxes as a camera above the table
// sees them (visible faces only, 5 mm samples like the scene's voxels).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <map>
#include <set>

#include "../core/preprocess_test_scene.hpp"
#include "mfot/object_discovery.hpp"

namespace mfot {
namespace {

const Eigen::Vector3f kCamera{0.3f, -0.6f, 0.6f};  // world frame: table z = 0, z up

struct View {
  std::vector<Eigen::Vector3f> positions;  // camera frame
  std::vector<Rgb8> colors;
  std::vector<int> box;  // which box each point samples
};

// Camera frame: at kCamera looking at the world origin, x right, y down, z forward (the preprocessing
// tests' camera).
Eigen::Matrix3f camera_from_world() {
  test_scene::Camera camera;
  camera.eye = kCamera;
  return camera.rotation().transpose();
}

// Samples the faces of the axis-aligned box [lo, hi] (no bottom) that face the camera, leaving out
// points inside `solid` boxes (faces hidden against a touching box).
void add_box(View& view, int id, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi,
             const std::vector<std::pair<Eigen::Vector3f, Eigen::Vector3f>>& solid) {
  const float step = 0.005f;
  const Eigen::Matrix3f r = camera_from_world();
  for (int axis = 0; axis < 3; ++axis) {
    for (int side = 0; side < 2; ++side) {
      if (axis == 2 && side == 0) continue;  // on the table
      Eigen::Vector3f normal = Eigen::Vector3f::Zero();
      normal[axis] = side ? 1.f : -1.f;
      const int a = (axis + 1) % 3, b = (axis + 2) % 3;
      for (float s = lo[a] + step / 2; s < hi[a]; s += step) {
        for (float t = lo[b] + step / 2; t < hi[b]; t += step) {
          Eigen::Vector3f p;
          p[axis] = side ? hi[axis] : lo[axis];
          p[a] = s;
          p[b] = t;
          if (normal.dot(kCamera - p) <= 0.f) continue;
          bool hidden = false;
          for (const auto& [slo, shi] : solid) {
            const Eigen::Vector3f q = p + 0.001f * normal;
            hidden |= (q.array() > slo.array()).all() && (q.array() < shi.array()).all();
          }
          if (hidden) continue;
          view.positions.push_back(r * (p - kCamera));
          view.colors.push_back(Rgb8{static_cast<std::uint8_t>(60 * id), 100, 100});
          view.box.push_back(id);
        }
      }
    }
  }
}

DiscoveryOptions lccp_options() {
  DiscoveryOptions options;
  options.method = DiscoveryMethod::kLccp;
  return options;
}

// Each box's points lie (>= 95 %) in one part and different boxes in different parts.
void expect_boxes_apart(const View& view, const std::vector<int>& part, int boxes) {
  std::map<int, std::map<int, int>> count;  // box -> part -> points
  std::map<int, int> size;
  for (std::size_t i = 0; i < part.size(); ++i) {
    ++count[view.box[i]][part[i]];
    ++size[view.box[i]];
  }
  std::set<int> parts_used;
  for (int b = 0; b < boxes; ++b) {
    int best_part = -1, best = 0;
    for (const auto& [p, c] : count[b]) {
      if (c > best) best = c, best_part = p;
    }
    EXPECT_GE(best, 0.95 * size[b]) << "box " << b;
    EXPECT_TRUE(parts_used.insert(best_part).second) << "box " << b << " shares part " << best_part;
  }
}

TEST(LccpDiscovery, ClustersGivesNoDiscovery) {
  DiscoveryOptions options;
  options.method = DiscoveryMethod::kClusters;
  EXPECT_EQ(make_object_discovery(options), nullptr);
}

TEST(LccpDiscovery, OneBoxStaysOneObject) {
  View view;
  add_box(view, 0, {-0.05f, -0.05f, 0.f}, {0.05f, 0.05f, 0.12f}, {});
  auto discovery = make_object_discovery(lccp_options());
  std::vector<int> part;
  EXPECT_EQ(discovery->split(view.positions, view.colors, part), 1);
  ASSERT_EQ(part.size(), view.positions.size());
  for (const int p : part) EXPECT_EQ(p, 0);
}

TEST(LccpDiscovery, TouchingBoxesOfDifferentHeightsComeApart) {
  View view;
  const Eigen::Vector3f alo{-0.1f, -0.05f, 0.f}, ahi{0.f, 0.05f, 0.12f};
  const Eigen::Vector3f blo{0.f, -0.03f, 0.f}, bhi{0.1f, 0.05f, 0.06f};  // set back: no flush front face
  add_box(view, 0, alo, ahi, {{blo, bhi}});
  add_box(view, 1, blo, bhi, {{alo, ahi}});
  auto discovery = make_object_discovery(lccp_options());
  std::vector<int> part;
  EXPECT_EQ(discovery->split(view.positions, view.colors, part), 2);
  expect_boxes_apart(view, part, 2);
}

TEST(LccpDiscovery, StackedBoxComesApartFromTheOneBelow) {
  View view;
  const Eigen::Vector3f lo{-0.1f, -0.08f, 0.f}, hi{0.1f, 0.08f, 0.08f};
  const Eigen::Vector3f top_lo{-0.04f, -0.04f, 0.08f}, top_hi{0.05f, 0.04f, 0.16f};
  add_box(view, 0, lo, hi, {{top_lo, top_hi}});
  add_box(view, 1, top_lo, top_hi, {{lo, hi}});
  auto discovery = make_object_discovery(lccp_options());
  std::vector<int> part;
  EXPECT_EQ(discovery->split(view.positions, view.colors, part), 2);
  expect_boxes_apart(view, part, 2);
}

TEST(LccpDiscovery, PiecesBelowTheMinimumJoinTheirNeighbour) {
  View view;
  const Eigen::Vector3f lo{-0.1f, -0.08f, 0.f}, hi{0.1f, 0.08f, 0.08f};
  const Eigen::Vector3f bump_lo{0.f, 0.f, 0.08f}, bump_hi{0.03f, 0.03f, 0.11f};  // < 150 points
  add_box(view, 0, lo, hi, {{bump_lo, bump_hi}});
  add_box(view, 1, bump_lo, bump_hi, {{lo, hi}});
  ASSERT_LT(std::count(view.box.begin(), view.box.end(), 1), 150);
  auto discovery = make_object_discovery(lccp_options());
  std::vector<int> part;
  EXPECT_EQ(discovery->split(view.positions, view.colors, part), 1);
  DiscoveryOptions small = lccp_options();
  small.min_part_points = 20;
  EXPECT_EQ(make_object_discovery(small)->split(view.positions, view.colors, part), 2);
}

TEST(LccpDiscovery, ABottlesNeckStaysPartOfItsBody) {
  // A bottle as boxes: an 8 x 8 x 14 cm body with a 3 x 3 x 6 cm neck on its top (about 180 points seen):
  // concave where they meet, like a box standing on another, but too small a part to be an object.
  View view;
  const Eigen::Vector3f lo{-0.04f, -0.04f, 0.f}, hi{0.04f, 0.04f, 0.14f};
  const Eigen::Vector3f neck_lo{-0.015f, -0.015f, 0.14f}, neck_hi{0.015f, 0.015f, 0.20f};
  add_box(view, 0, lo, hi, {{neck_lo, neck_hi}});
  add_box(view, 1, neck_lo, neck_hi, {{lo, hi}});
  ASSERT_LT(std::count(view.box.begin(), view.box.end(), 1), 250);
  std::vector<int> part;
  EXPECT_EQ(make_object_discovery(lccp_options())->split(view.positions, view.colors, part), 1);
  DiscoveryOptions small = lccp_options();
  small.min_part_points = 150;  // the neck alone is a part: LCCP cuts at the concave shoulder
  EXPECT_EQ(make_object_discovery(small)->split(view.positions, view.colors, part), 2);
}

TEST(LccpDiscovery, SameInputSameParts) {
  View view;
  add_box(view, 0, {-0.1f, -0.05f, 0.f}, {0.f, 0.05f, 0.12f}, {});
  add_box(view, 1, {0.f, -0.05f, 0.f}, {0.1f, 0.05f, 0.06f}, {});
  auto discovery = make_object_discovery(lccp_options());
  std::vector<int> first, second;
  discovery->split(view.positions, view.colors, first);
  discovery->split(view.positions, view.colors, second);
  EXPECT_EQ(first, second);
}

TEST(DiscoveryOptions, RejectsOutOfRangeFields) {
  DiscoveryOptions o;
  o.seed_resolution = 0.001f;  // below voxel_resolution
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o = {};
  o.min_part_points = 0;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  EXPECT_EQ(parse_discovery_method("lccp"), DiscoveryMethod::kLccp);
  EXPECT_THROW(parse_discovery_method("convex"), std::invalid_argument);
}

}  // namespace
}  // namespace mfot
