#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>
#include <stdexcept>
#include <string>

#include "expect_invalid_argument.hpp"
#include "mfot/individuation.hpp"
#include "mfot/preprocessing.hpp"
#include "preprocess_test_scene.hpp"

namespace mfot {
namespace {

using test_scene::Camera;
using test_scene::Frame;

// Index of the box (inflated by `slack`) that world point w lies in, or -1.
int box_of(const test_scene::Scene& scene, const Eigen::Vector3f& w, float slack) {
  for (std::size_t b = 0; b < scene.boxes.size(); ++b) {
    const auto& box = scene.boxes[b];
    if ((w.array() >= box.min.array() - slack).all() && (w.array() <= box.max.array() + slack).all()) {
      return static_cast<int>(b);
    }
  }
  return -1;
}

Frame constant_depth_frame(int width, int height, std::uint16_t left_mm, std::uint16_t right_mm) {
  Frame frame;
  frame.width = width;
  frame.height = height;
  frame.intrinsics = CameraIntrinsics{100.f, 100.f, (width - 1) / 2.f, (height - 1) / 2.f};
  frame.depth_mm.resize(static_cast<std::size_t>(width * height));
  frame.color.assign(frame.depth_mm.size(), Rgb8{10, 20, 30});
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u)
      frame.depth_mm[static_cast<std::size_t>(v * width + u)] = u < width / 2 ? left_mm : right_mm;
  }
  return frame;
}

// Each voxel of the preprocessor's last scene (cloud) holds its recorded pixel: that pixel maps back to the voxel,
// its 3D point does too, and the voxel's mean lies in the same cell of the scene's grid (its leaf and corner).
void expect_voxels_hold_their_pixels(const Preprocessor& preprocessor, const SceneCloud& cloud, const Frame& frame) {
  const auto& k = frame.intrinsics;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const int u = cloud.pixel_u[i];
    const int v = cloud.pixel_v[i];
    EXPECT_EQ(preprocessor.voxel_index_at(u, v), static_cast<int>(i));
    const float z = frame.depth_mm[static_cast<std::size_t>(v * frame.width + u)] * 0.001f;
    const Eigen::Vector3f p((u - k.cx) / k.fx * z, (v - k.cy) / k.fy * z, z);
    EXPECT_EQ(preprocessor.voxel_index_of(p), static_cast<int>(i));
    EXPECT_EQ(cloud.voxel_grid.cell_of(p), cloud.voxel_grid.cell_of(cloud.positions[i]));
  }
}

// test_scene::two_boxes() from the default camera, with this depth noise.
Frame two_boxes_frame(float depth_noise_mm) {
  Camera camera;
  camera.depth_noise_mm = depth_noise_mm;
  return test_scene::render(test_scene::two_boxes(), camera);
}

void expect_plane_near(const TablePlane& plane, const Eigen::Vector4f& expected) {
  ASSERT_TRUE(plane.valid);
  EXPECT_NEAR(plane.coefficients.head<3>().norm(), 1.f, 1e-4f);
  EXPECT_GT(plane.coefficients.head<3>().dot(expected.head<3>()), std::cos(1.0f * 3.14159265f / 180.f));
  EXPECT_NEAR(plane.coefficients[3], expected[3], 0.004f);
}

TEST(Preprocessor, FindsTablePlaneAndSeparatesBoxes) {
  const auto scene = test_scene::two_boxes();
  const Frame frame = two_boxes_frame(2.f);

  Preprocessor preprocessor;
  const SceneCloud& cloud = preprocessor.process(frame.view());

  const Camera camera;
  expect_plane_near(cloud.plane, camera.table_plane());
  expect_plane_near(preprocessor.plane(), camera.table_plane());
  EXPECT_TRUE(preprocessor.stats().plane_refitted);
  ASSERT_FALSE(cloud.empty());
  ASSERT_EQ(cloud.num_clusters, 2);

  // Every surviving voxel lies on a box (nothing of the table survives), each cluster on one box.
  std::set<std::pair<int, int>> cluster_box_pairs;
  int clustered = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    ASSERT_TRUE(cloud.positions[i].allFinite());
    const Eigen::Vector3f world = camera.camera_to_world(cloud.positions[i]);
    const int box = box_of(scene, world, 0.01f);
    EXPECT_GE(box, 0) << "voxel " << i << " at world " << world.transpose();
    EXPECT_GT(world.z(), 0.005f);
    if (cloud.cluster[i] >= 0) {
      cluster_box_pairs.insert({cloud.cluster[i], box});
      ++clustered;
    }
  }
  EXPECT_EQ(cluster_box_pairs.size(), 2u);  // two clusters, each on exactly one box
  std::set<int> boxes_seen;
  for (const auto& [cluster, box] : cluster_box_pairs) boxes_seen.insert(box);
  EXPECT_EQ(boxes_seen.size(), 2u);
  // Faces seen edge-on break into small fragments below cluster_min_size; they are few.
  EXPECT_GT(clustered, static_cast<int>(cloud.size() * 95 / 100));

  // Voxel colours are the box colours (boxes are uniformly coloured).
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const int box = box_of(scene, camera.camera_to_world(cloud.positions[i]), 0.01f);
    if (box >= 0) {
      EXPECT_EQ(cloud.colors[i], scene.boxes[static_cast<std::size_t>(box)].color);
    }
  }
}

TEST(Preprocessor, TablePrismLeavesClustersBesideTheTableStandingNot) {
  auto scene = test_scene::two_boxes();
  scene.table_half_extent = 0.32f;
  // A post beside the table (a chair, a shelf), rising above the table's height.
  scene.boxes.push_back(test_scene::Box{{0.40f, -0.05f, -0.6f}, {0.48f, 0.03f, 0.20f}, Rgb8{30, 30, 200}});
  const Frame frame = test_scene::render(scene, Camera{});
  PreprocessorOptions options;
  Preprocessor without(options);
  const SceneCloud& all = without.process(frame.view());
  EXPECT_EQ(all.num_clusters, 3);
  EXPECT_EQ(all.standing_clusters, 3);
  EXPECT_TRUE(without.table_polygon().empty());
  options.table_prism = true;
  Preprocessor with(options);
  const SceneCloud& on_table = with.process(frame.view());
  // The post keeps its points together, numbered after the two boxes that stand.
  ASSERT_EQ(on_table.num_clusters, 3);
  EXPECT_EQ(on_table.standing_clusters, 2);
  EXPECT_EQ(with.stats().clusters_off_table, 1);
  int post_voxels = 0;
  for (std::size_t i = 0; i < on_table.size(); ++i) {
    const int box = box_of(scene, Camera{}.camera_to_world(on_table.positions[i]), 0.01f);
    if (box == 2) {
      EXPECT_EQ(on_table.cluster[i], 2);
      ++post_voxels;
    } else {
      EXPECT_LT(on_table.cluster[i], 2);
    }
  }
  EXPECT_GT(post_voxels, 0);
  // The support polygon is the table's visible top: its corners lie within the table.
  ASSERT_GE(with.table_polygon().size(), 4u);
  EXPECT_FALSE(
      inside_convex_polygon(with.table_polygon(), with.on_table_plane(Camera{}.world_to_camera({0.44f, 0.f, 0.1f}))));
  EXPECT_TRUE(
      inside_convex_polygon(with.table_polygon(), with.on_table_plane(Camera{}.world_to_camera({0.f, 0.f, 0.1f}))));
}

TEST(Preprocessor, PlaneMarginGrowsWithDepth) {
  test_scene::Scene scene;
  scene.boxes.push_back(
      test_scene::Box{{-0.05f, -0.05f, 0.f}, {0.05f, 0.05f, 0.015f}, Rgb8{200, 30, 30}});  // 15 mm tall
  Camera far;                                                                              // about 1.9 m from the box
  far.eye = {0.f, -1.3f, 1.4f};
  const Frame frame = test_scene::render(scene, far);
  PreprocessorOptions options;
  Preprocessor fixed(options);
  EXPECT_GT(fixed.process(frame.view()).size(), 20u);  // 1 cm margin: its top survives
  options.plane_margin_sigmas = 3.f;                   // 3 sigma at 1.9 m: 1.6 cm
  Preprocessor growing(options);
  EXPECT_EQ(growing.process(frame.view()).size(), 0u);
  const Frame near = test_scene::render(scene, Camera{});  // about 1 m: 3 sigma = 5.6 mm, the 1 cm margin holds
  Preprocessor fixed_near(PreprocessorOptions{}), growing_near(options);
  EXPECT_EQ(growing_near.process(near.view()).size(), fixed_near.process(near.view()).size());
}

TEST(ConvexHull, CounterClockwiseCornersAndInsideTest) {
  std::vector<Eigen::Vector2f> points{{0, 0}, {2, 0}, {2, 2}, {0, 2}, {1, 1}, {1, 0}, {0.5f, 1.5f}};
  const auto hull = convex_hull(points);
  ASSERT_EQ(hull.size(), 4u);  // the collinear (1, 0) and inner points are no corners
  EXPECT_EQ(hull[0], Eigen::Vector2f(0, 0));
  EXPECT_EQ(hull[1], Eigen::Vector2f(2, 0));
  EXPECT_EQ(hull[2], Eigen::Vector2f(2, 2));
  EXPECT_EQ(hull[3], Eigen::Vector2f(0, 2));
  EXPECT_TRUE(inside_convex_polygon(hull, {1.f, 1.f}));
  EXPECT_TRUE(inside_convex_polygon(hull, {2.f, 1.f}));  // on an edge
  EXPECT_FALSE(inside_convex_polygon(hull, {2.1f, 1.f}));
  EXPECT_FALSE(inside_convex_polygon(std::span<const Eigen::Vector2f>(hull.data(), 2), {1.f, 0.f}));
  EXPECT_EQ(convex_hull({{1, 1}, {1, 1}}).size(), 1u);
}

TEST(Preprocessor, VoxelsAreSparserThanLeafAndPixelsMapBack) {
  const auto scene = test_scene::two_boxes();
  const Camera camera;
  const Frame frame = test_scene::render(scene, camera);
  Preprocessor preprocessor;
  const SceneCloud& cloud = preprocessor.process(frame.view());
  ASSERT_FALSE(cloud.empty());

  // The recorded pixel of each voxel maps back to that voxel, its 3D point does too, and the mean lies inside it
  // (the fixed 5 mm grid at the origin).
  EXPECT_EQ(cloud.voxel_grid.leaf, 0.005f);
  EXPECT_EQ(cloud.voxel_grid.corner, Eigen::Vector3f::Zero());
  expect_voxels_hold_their_pixels(preprocessor, cloud, frame);
  // Dense labels: table pixels and empty pixels are -1, box pixels point at a voxel.
  const auto labels = preprocessor.pixel_voxel_index();
  ASSERT_EQ(labels.size(), frame.depth_mm.size());
  std::size_t labelled = 0;
  for (std::size_t i = 0; i < labels.size(); ++i) {
    if (labels[i] < 0) continue;
    ++labelled;
    ASSERT_LT(labels[i], static_cast<int>(cloud.size()));
    EXPECT_NE(frame.color[i], scene.table_color);
  }
  EXPECT_EQ(labelled, preprocessor.stats().above_plane);
  EXPECT_GT(labelled, cloud.size());  // several pixels per 5 mm voxel at this distance
  EXPECT_EQ(preprocessor.voxel_index_at(-1, 0), -1);
  EXPECT_EQ(preprocessor.voxel_index_at(frame.width, 0), -1);
  EXPECT_EQ(preprocessor.voxel_index_at(0, frame.height), -1);
}

TEST(Preprocessor, JitteredGridMovesEveryFrameAndReplaysByTheFramesSeq) {
  const Frame frame = two_boxes_frame(2.f);
  PreprocessorOptions options;
  options.voxel_jitter = true;
  Preprocessor forward(options);
  Preprocessor backward(options);

  // The same frame under seqs 1, 2, 3, and under 3, 2, 1 in another preprocessor: each seq's grid (and
  // so its scene) is the same whatever came before, and no two seqs share a grid.
  std::vector<SceneCloud> by_seq(4);
  for (std::int64_t seq = 1; seq <= 3; ++seq)
    by_seq[static_cast<std::size_t>(seq)] = forward.process(frame.view(), seq);
  for (std::int64_t seq = 3; seq >= 1; --seq) {
    const SceneCloud& again = backward.process(frame.view(), seq);
    const SceneCloud& first = by_seq[static_cast<std::size_t>(seq)];
    EXPECT_EQ(again.voxel_grid.corner, first.voxel_grid.corner);
    ASSERT_EQ(again.positions, first.positions);
    EXPECT_EQ(again.num_clusters, 2);
  }
  for (std::size_t seq = 1; seq <= 3; ++seq) {
    const SceneCloud& cloud = by_seq[seq];
    const Eigen::Vector3f& corner = cloud.voxel_grid.corner;
    EXPECT_EQ(cloud.voxel_grid.leaf, options.voxel_size);  // the grid travels whole: its leaf and its corner
    EXPECT_TRUE((corner.array() >= 0.f).all() && (corner.array() < options.voxel_size).all()) << corner.transpose();
    for (std::size_t other = seq + 1; other <= 3; ++other) {
      EXPECT_NE(corner, by_seq[other].voxel_grid.corner);
      EXPECT_NE(cloud.positions, by_seq[other].positions);  // another grid, other voxel means
    }
  }

  // Each voxel's mean and its recorded pixel's point lie in one cell of the moved grid (seq 1, the last processed).
  expect_voxels_hold_their_pixels(backward, backward.scene(), frame);

  // Off (the default): the grid stays at the origin for every seq.
  Preprocessor fixed;
  EXPECT_EQ(fixed.process(frame.view(), 5).voxel_grid.corner, Eigen::Vector3f::Zero());
  const std::vector<Eigen::Vector3f> at_five = fixed.scene().positions;
  EXPECT_EQ(fixed.process(frame.view(), 6).positions, at_five);
}

TEST(Preprocessor, PlaneKeptWhileItFitsAndRefittedWhenCameraMoves) {
  const auto scene = test_scene::two_boxes();
  Camera camera;
  camera.depth_noise_mm = 1.f;
  Preprocessor preprocessor;

  preprocessor.process(test_scene::render(scene, camera).view());
  EXPECT_TRUE(preprocessor.stats().plane_refitted);
  const TablePlane first = preprocessor.plane();
  expect_plane_near(first, camera.table_plane());

  camera.noise_seed = 2;  // new noise, same geometry: the kept plane still fits
  preprocessor.process(test_scene::render(scene, camera).view());
  EXPECT_FALSE(preprocessor.stats().plane_refitted);
  EXPECT_EQ(preprocessor.plane().coefficients, first.coefficients);
  EXPECT_GT(preprocessor.stats().plane_inlier_share, 0.5f);

  camera.eye = Eigen::Vector3f(0.3f, -0.5f, 0.9f);  // the camera moves: the old plane stops fitting
  preprocessor.process(test_scene::render(scene, camera).view());
  EXPECT_TRUE(preprocessor.stats().plane_refitted);
  expect_plane_near(preprocessor.plane(), camera.table_plane());
  EXPECT_EQ(preprocessor.scene().num_clusters, 2);

  preprocessor.reset_plane();
  EXPECT_FALSE(preprocessor.plane().valid);
  preprocessor.process(test_scene::render(scene, camera).view());
  EXPECT_TRUE(preprocessor.stats().plane_refitted);
}

TEST(Preprocessor, OutputIsDeterministic) {
  const auto scene = test_scene::two_boxes();
  Camera camera;
  camera.depth_noise_mm = 2.f;
  const Frame a = test_scene::render(scene, camera);
  camera.eye = Eigen::Vector3f(-0.2f, -0.6f, 0.8f);
  const Frame b = test_scene::render(scene, camera);

  Preprocessor first;
  Preprocessor second;
  for (const Frame* frame : {&a, &b, &a}) {
    const SceneCloud& x = first.process(frame->view());
    const SceneCloud& y = second.process(frame->view());
    ASSERT_EQ(x.size(), y.size());
    for (std::size_t i = 0; i < x.size(); ++i) {
      ASSERT_EQ(x.positions[i], y.positions[i]);
      ASSERT_EQ(x.colors[i], y.colors[i]);
      ASSERT_EQ(x.pixel_u[i], y.pixel_u[i]);
      ASSERT_EQ(x.pixel_v[i], y.pixel_v[i]);
      ASSERT_EQ(x.cluster[i], y.cluster[i]);
    }
    EXPECT_EQ(x.num_clusters, y.num_clusters);
    EXPECT_EQ(x.plane.coefficients, y.plane.coefficients);
  }
}

TEST(Preprocessor, CropBoxLimitsPoints) {
  // Left half at 1.0 m, right half at 2.5 m (beyond the default z <= 2.0 m).
  const Frame frame = constant_depth_frame(40, 30, 1000, 2500);
  PreprocessorOptions options;
  options.remove_plane = false;
  options.cluster = false;
  Preprocessor preprocessor(options);
  const SceneCloud& cloud = preprocessor.process(frame.view());
  ASSERT_FALSE(cloud.empty());
  EXPECT_EQ(preprocessor.stats().valid_depth, 40u * 30u);
  EXPECT_EQ(preprocessor.stats().cropped, 20u * 30u);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    EXPECT_NEAR(cloud.positions[i].z(), 1.0f, 1e-5f);
    EXPECT_LT(cloud.pixel_u[i], 20);
    EXPECT_EQ(cloud.colors[i], (Rgb8{10, 20, 30}));
    EXPECT_EQ(cloud.cluster[i], -1);  // clustering disabled
  }
  EXPECT_EQ(cloud.num_clusters, 0);
  EXPECT_FALSE(cloud.plane.valid);
  EXPECT_EQ(preprocessor.voxel_index_at(30, 10), -1);

  // Narrow the box in x to the left quarter: x <= -0.05 m (u < 14.5 at 1 m with fx = 100).
  options.crop_max.x() = -0.05f;
  Preprocessor narrow(options);
  const SceneCloud& narrow_cloud = narrow.process(frame.view());
  EXPECT_EQ(narrow.stats().cropped, 15u * 30u);
  for (std::size_t i = 0; i < narrow_cloud.size(); ++i) EXPECT_LE(narrow_cloud.positions[i].x(), -0.05f + 0.005f);
}

TEST(Preprocessor, EmptyAndZeroDepthGiveEmptyScene) {
  Preprocessor preprocessor;
  const Frame zeros = constant_depth_frame(64, 48, 0, 0);
  const SceneCloud& cloud = preprocessor.process(zeros.view());
  EXPECT_TRUE(cloud.empty());
  EXPECT_EQ(cloud.num_clusters, 0);
  EXPECT_EQ(preprocessor.stats().valid_depth, 0u);
  EXPECT_FALSE(preprocessor.plane().valid);
  EXPECT_EQ(preprocessor.voxel_index_at(3, 3), -1);
  EXPECT_EQ(preprocessor.voxel_index_of(Eigen::Vector3f(0.f, 0.f, 1.f)), -1);

  const Frame empty = constant_depth_frame(0, 0, 0, 0);
  EXPECT_TRUE(preprocessor.process(empty.view()).empty());

  // Everything beyond the crop box: empty as well.
  const Frame far = constant_depth_frame(64, 48, 5000, 6000);
  EXPECT_TRUE(preprocessor.process(far.view()).empty());

  // A valid frame after the empty ones still works (buffers grow after warm-up).
  const Frame frame = test_scene::render(test_scene::two_boxes(), Camera{});
  EXPECT_EQ(preprocessor.process(frame.view()).num_clusters, 2);
  EXPECT_TRUE(preprocessor.process(zeros.view()).empty());
  EXPECT_TRUE(preprocessor.plane().valid);  // nothing seen: the kept plane stays
}

TEST(Preprocessor, NoDominantPlaneKeepsAllPoints) {
  // Depths scattered over 1.4 m: no plane holds 10 % of the points within 1 cm.
  Frame frame = constant_depth_frame(64, 48, 0, 0);
  std::mt19937_64 rng(5);
  for (auto& d : frame.depth_mm) d = static_cast<std::uint16_t>(500 + (rng() >> 32) % 1400);
  PreprocessorOptions options;
  options.cluster = false;
  Preprocessor preprocessor(options);
  preprocessor.process(frame.view());
  EXPECT_FALSE(preprocessor.plane().valid);
  EXPECT_TRUE(preprocessor.stats().plane_refitted);
  EXPECT_EQ(preprocessor.stats().above_plane, preprocessor.stats().cropped);
}

TEST(Preprocessor, SmallClustersAreRejected) {
  auto scene = test_scene::two_boxes();
  scene.boxes.push_back(test_scene::Box{{0.0f, -0.3f, 0.f}, {0.012f, -0.288f, 0.02f}, Rgb8{0, 0, 255}});  // 12 mm pin
  const Camera camera;
  const Frame frame = test_scene::render(scene, camera);
  Preprocessor preprocessor;
  const SceneCloud& cloud = preprocessor.process(frame.view());
  EXPECT_EQ(cloud.num_clusters, 2);
  int pin_voxels = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (box_of(scene, camera.camera_to_world(cloud.positions[i]), 0.005f) == 2) {
      ++pin_voxels;
      EXPECT_EQ(cloud.cluster[i], -1);
    }
  }
  EXPECT_GT(pin_voxels, 0);

  // Without the size limit the pin is a cluster of its own, shared with no box.
  PreprocessorOptions options;
  options.cluster_min_size = 1;
  Preprocessor keep_all(options);
  const SceneCloud& all = keep_all.process(frame.view());
  EXPECT_GE(all.num_clusters, 3);
  std::set<int> pin_clusters;
  std::set<int> box_clusters;
  for (std::size_t i = 0; i < all.size(); ++i) {
    ASSERT_GE(all.cluster[i], 0);
    const int box = box_of(scene, camera.camera_to_world(all.positions[i]), 0.005f);
    (box == 2 ? pin_clusters : box_clusters).insert(all.cluster[i]);
  }
  EXPECT_EQ(pin_clusters.size(), 1u);
  for (const int c : pin_clusters) EXPECT_EQ(box_clusters.count(c), 0u);
}

TEST(Preprocessor, ClustersMatchEuclideanClusterer) {
  auto scene = test_scene::two_boxes();
  scene.boxes.push_back(test_scene::Box{{-0.02f, 0.2f, 0.f}, {0.05f, 0.25f, 0.15f}, Rgb8{250, 250, 0}});
  scene.boxes.push_back(test_scene::Box{{0.061f, 0.2f, 0.f}, {0.1f, 0.25f, 0.05f}, Rgb8{0, 250, 250}});  // 11 mm gap
  Camera camera;
  camera.depth_noise_mm = 3.f;
  const Frame frame = test_scene::render(scene, camera);
  // 5, 7.07 and 8.66 mm: the 5 mm voxels' spacing along an axis, a face and a cube diagonal, where
  // many pairs lie at the tolerance; threads: the concurrent union-find.
  for (const float tolerance : {0.005f, 0.00707f, 0.00866f, 0.006f, 0.015f, 0.03f}) {
    for (const int min_size : {1, 30}) {
      for (const int threads : {1, 4}) {
        PreprocessorOptions options;
        options.cluster_tolerance = tolerance;
        options.cluster_min_size = min_size;
        options.threads = threads;
        Preprocessor preprocessor(options);
        const SceneCloud& cloud = preprocessor.process(frame.view());
        EuclideanClusterer reference(EuclideanClusterOptions{tolerance, static_cast<std::size_t>(min_size)});
        ClusterSet expected;
        reference.cluster(cloud.positions, expected);
        ASSERT_EQ(cloud.num_clusters, static_cast<int>(expected.size())) << "tolerance " << tolerance;
        EXPECT_EQ(cloud.cluster, std::vector<int>(expected.cluster_of_point.begin(), expected.cluster_of_point.end()))
            << "tolerance " << tolerance << " min size " << min_size << " threads " << threads;
      }
    }
  }
}

TEST(Preprocessor, RejectsInvalidInput) {
  Preprocessor preprocessor;
  Frame frame = constant_depth_frame(8, 6, 1000, 1000);
  frame.color.pop_back();
  EXPECT_THROW(preprocessor.process(frame.view()), std::invalid_argument);
  frame = constant_depth_frame(8, 6, 1000, 1000);
  frame.intrinsics.fx = 0.f;
  EXPECT_THROW(preprocessor.process(frame.view()), std::invalid_argument);
  frame.intrinsics.fx = std::nanf("");
  EXPECT_THROW(preprocessor.process(frame.view()), std::invalid_argument);
}

void expect_invalid_option(const PreprocessorOptions& options, const std::string& field) {
  test::expect_invalid_argument([&] { Preprocessor preprocessor(options); }, field);
}

TEST(PreprocessorOptions, InvalidValuesNameTheField) {
  PreprocessorOptions o;
  o.voxel_size = 0.f;
  expect_invalid_option(o, "voxel_size");
  o = {};
  o.crop_min.z() = 3.f;
  expect_invalid_option(o, "crop_min");
  o = {};
  o.plane_margin = -0.01f;
  expect_invalid_option(o, "plane_margin");
  o = {};
  o.plane_keep_ratio = 1.5f;
  expect_invalid_option(o, "plane_keep_ratio");
  o = {};
  o.cluster_tolerance = std::nanf("");
  expect_invalid_option(o, "cluster_tolerance");
  o = {};
  o.cluster_min_size = 0;
  expect_invalid_option(o, "cluster_min_size");
  o = {};
  o.plane_fit.iterations = 0;
  expect_invalid_option(o, "iterations");
  o = {};
  o.plane_fit.inlier_distance = 0.f;
  expect_invalid_option(o, "inlier_distance");
  EXPECT_NO_THROW(PreprocessorOptions{}.validate());
}

TEST(VoxelDownsampler, MeansCountsAndOrderOnHandMadeInput) {
  VoxelDownsampler voxels(0.1f);
  const std::vector<Eigen::Vector3f> positions = {
      {0.01f, 0.01f, 0.01f},   // voxel (0,0,0)
      {0.15f, 0.01f, 0.01f},   // voxel (1,0,0)
      {0.03f, 0.05f, 0.07f},   // voxel (0,0,0)
      {-0.01f, 0.02f, 0.03f},  // voxel (-1,0,0)
      {0.11f, 0.09f, 0.05f},   // voxel (1,0,0)
      {0.02f, 0.06f, 0.02f},   // voxel (0,0,0)
  };
  const std::vector<Rgb8> colors = {{10, 0, 0}, {0, 100, 0}, {20, 0, 1}, {1, 2, 3}, {0, 51, 0}, {31, 0, 1}};
  const std::vector<std::uint32_t> ids = {7, 8, 9, 10, 11, 12};
  ASSERT_EQ(voxels.downsample(positions, colors, ids), 3u);

  // Order of first appearance.
  EXPECT_TRUE(voxels.positions()[0].isApprox(Eigen::Vector3f(0.02f, 0.04f, 0.10f / 3.f), 1e-6f));
  EXPECT_TRUE(voxels.positions()[1].isApprox(Eigen::Vector3f(0.13f, 0.05f, 0.03f), 1e-6f));
  EXPECT_TRUE(voxels.positions()[2].isApprox(Eigen::Vector3f(-0.01f, 0.02f, 0.03f), 1e-6f));
  EXPECT_EQ(voxels.colors()[0], (Rgb8{20, 0, 1}));  // (10+20+31)/3 = 20.3, (0+1+1)/3 = 0.67 -> 1
  EXPECT_EQ(voxels.colors()[1], (Rgb8{0, 76, 0}));  // (100+51)/2 = 75.5 rounds up
  EXPECT_EQ(voxels.colors()[2], (Rgb8{1, 2, 3}));
  EXPECT_EQ(voxels.point_counts()[0], 3);
  EXPECT_EQ(voxels.point_counts()[1], 2);
  EXPECT_EQ(voxels.point_counts()[2], 1);
  EXPECT_EQ(voxels.first_source_ids()[0], 7u);
  EXPECT_EQ(voxels.first_source_ids()[1], 8u);
  EXPECT_EQ(voxels.first_source_ids()[2], 10u);
  const std::vector<int> expected_voxel_of = {0, 1, 0, 2, 1, 0};
  EXPECT_EQ(std::vector<int>(voxels.voxel_of_input().begin(), voxels.voxel_of_input().end()), expected_voxel_of);

  EXPECT_EQ(voxels.voxel_index_of({0.099f, 0.f, 0.f}), 0);
  EXPECT_EQ(voxels.voxel_index_of({0.1999f, 0.0999f, 0.0999f}), 1);
  EXPECT_EQ(voxels.voxel_index_of({-0.05f, 0.05f, 0.05f}), 2);
  EXPECT_EQ(voxels.voxel_index_of({0.25f, 0.f, 0.f}), -1);
  EXPECT_EQ(voxels.voxel_index_of({0.f, -0.01f, 0.f}), -1);
  EXPECT_EQ(voxels.voxel_index_of({std::nanf(""), 0.f, 0.f}), -1);

  // A second call replaces the voxel set.
  ASSERT_EQ(voxels.downsample(std::span(positions).subspan(3, 1), std::span(colors).subspan(3, 1),
                              std::span(ids).subspan(3, 1)),
            1u);
  EXPECT_EQ(voxels.voxel_index_of({0.01f, 0.01f, 0.01f}), -1);
  EXPECT_EQ(voxels.voxel_index_of({-0.01f, 0.02f, 0.03f}), 0);

  EXPECT_THROW(VoxelDownsampler(0.f), std::invalid_argument);
  EXPECT_THROW(voxels.downsample(positions, std::span(colors).subspan(1), ids), std::invalid_argument);
}

TEST(VoxelDownsampler, AMovedGridRegroupsThePoints) {
  VoxelDownsampler voxels(0.1f);
  const std::vector<Eigen::Vector3f> positions = {
      {0.01f, 0.01f, 0.01f}, {0.15f, 0.01f, 0.01f}, {0.03f, 0.05f, 0.07f}, {0.11f, 0.09f, 0.05f}};
  const std::vector<Rgb8> colors(positions.size(), Rgb8{1, 2, 3});
  const std::vector<std::uint32_t> ids = {0, 1, 2, 3};
  ASSERT_EQ(voxels.downsample(positions, colors, ids), 2u);  // x cells 0, 1, 0, 1

  // Cells start at x = 0.05: x cells -1, 1, -1, 0.
  voxels.set_grid_origin({0.05f, 0.f, 0.f});
  EXPECT_EQ(voxels.grid_origin(), Eigen::Vector3f(0.05f, 0.f, 0.f));
  ASSERT_EQ(voxels.downsample(positions, colors, ids), 3u);
  const std::vector<int> expected_voxel_of = {0, 1, 0, 2};
  EXPECT_EQ(std::vector<int>(voxels.voxel_of_input().begin(), voxels.voxel_of_input().end()), expected_voxel_of);
  EXPECT_TRUE(voxels.positions()[0].isApprox(Eigen::Vector3f(0.02f, 0.03f, 0.04f), 1e-6f));
  EXPECT_EQ(voxels.voxel_index_of({-0.04f, 0.f, 0.f}), 0);
  EXPECT_EQ(voxels.voxel_index_of({0.051f, 0.f, 0.f}), 2);
  EXPECT_EQ(voxels.voxel_index_of({0.149f, 0.05f, 0.05f}), 2);

  EXPECT_THROW(voxels.set_grid_origin({std::nanf(""), 0.f, 0.f}), std::invalid_argument);
  EXPECT_EQ(voxels.grid_origin(), Eigen::Vector3f(0.05f, 0.f, 0.f));
}

TEST(PlaneFitter, FitsNoisyPlaneWithOutliersAndRejectsClutter) {
  std::mt19937_64 rng(3);
  auto unit = [&rng] { return static_cast<float>(rng() >> 40) / static_cast<float>(1u << 24); };
  const Eigen::Vector3f normal = Eigen::Vector3f(0.1f, -0.8f, -0.5f).normalized();
  const float offset = 0.9f;  // positive: normal points to the origin side
  const Eigen::Vector3f u = normal.unitOrthogonal();
  const Eigen::Vector3f w = normal.cross(u);
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < 6000; ++i) {
    const Eigen::Vector3f on_plane = -offset * normal + (unit() - 0.5f) * u + (unit() - 0.5f) * w;
    points.push_back(on_plane + (unit() - 0.5f) * 0.004f * normal);
  }
  for (int i = 0; i < 3000; ++i) points.emplace_back(unit() - 0.5f, unit() - 0.5f, 0.5f + unit());

  PlaneFitter fitter;
  float share = 0.f;
  const TablePlane plane = fitter.fit(points, &share);
  ASSERT_TRUE(plane.valid);
  EXPECT_GT(plane.coefficients.head<3>().dot(normal), std::cos(0.5f * 3.14159265f / 180.f));
  EXPECT_NEAR(plane.coefficients[3], offset, 0.002f);
  EXPECT_GT(share, 0.6f);
  EXPECT_LT(share, 0.75f);

  std::vector<Eigen::Vector3f> clutter;
  for (int i = 0; i < 3000; ++i) clutter.emplace_back(unit() - 0.5f, unit() - 0.5f, 0.5f + unit());
  EXPECT_FALSE(fitter.fit(clutter).valid);
  EXPECT_FALSE(fitter.fit(std::span(clutter).first(2)).valid);
}

}  // namespace
}  // namespace mfot
