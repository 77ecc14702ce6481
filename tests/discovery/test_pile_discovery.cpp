// First-frame objects of synthetic piles, through the shipped pipeline (configs/default.yaml's preprocess and
// merger sections, the simulator's Kinect-like sensor): fifteen boxes and cylinders touching, leaning on each other,
// stacked and lying flat on each other, the pile running out of the image on the left. An object is found when one
// object holds it with IoU >= 0.5 over the scene's voxels; over three sensor-noise seeds at least 95 % must be (the
// issue's target for procedural clutter), none spurious, and almost no point of the pile left in no object.
// MFOT_PILE_CONFIG=FILE lays a config over the defaults, MFOT_PILE_DEBUG=1 prints which objects hold each body.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <vector>

#include "mfot/object_discovery.hpp"
#include "mfot/object_manager.hpp"
#include "mfot/preprocessing.hpp"
#include "mfot/service/config.hpp"
#include "mfot/service/pipeline_config.hpp"
#include "mfot/sim/scene.hpp"

namespace mfot {
namespace {

constexpr float kPi = 3.14159265f;
constexpr float kGap = 0.0005f;  // between touching objects

struct Body {
  sim::PrimitiveKind kind;
  Eigen::Vector3f size;     // box edges / cylinder (diameter, diameter, height)
  Eigen::Isometry3f world;  // body -> world (table z = 0, z up)
  Rgb8 color;
};

Eigen::Isometry3f at(float x, float y, float z, float yaw_deg = 0.f, float tilt_y_deg = 0.f) {
  Eigen::Isometry3f t = Eigen::Isometry3f::Identity();
  t.linear() = (Eigen::AngleAxisf(yaw_deg * kPi / 180.f, Eigen::Vector3f::UnitZ()) *
                Eigen::AngleAxisf(tilt_y_deg * kPi / 180.f, Eigen::Vector3f::UnitY()))
                   .toRotationMatrix();
  t.translation() = Eigen::Vector3f(x, y, z);
  return t;
}

Body box(float sx, float sy, float sz, const Eigen::Isometry3f& pose, Rgb8 color) {
  return {sim::PrimitiveKind::box, {sx, sy, sz}, pose, color};
}
Body can(float d, float h, const Eigen::Isometry3f& pose, Rgb8 color) {
  return {sim::PrimitiveKind::cylinder, {d, d, h}, pose, color};
}

// The pile, left to right: a run of touching boxes leaving the image's left border, a box leaning on a tall one,
// boxes of different heights and a can touching in a row, a flat book lying on a wide box with a small box on
// top, and three touching cans behind.
std::vector<Body> pile() {
  std::vector<Body> b;
  // Touching boxes running out of the image (about x = -0.56 at the pile's depth).
  b.push_back(box(0.10f, 0.08f, 0.12f, at(-0.531f, 0.05f, 0.06f), {200, 30, 35}));
  b.push_back(box(0.10f, 0.10f, 0.08f, at(-0.4305f, 0.05f, 0.04f), {35, 160, 60}));
  b.push_back(box(0.12f, 0.10f, 0.07f, at(-0.32f, 0.05f, 0.035f), {35, 70, 200}));
  // A thin box leaning on the tall one's left face, 20 degrees.
  const float tilt = 20.f * kPi / 180.f, half_h = 0.07f;
  const float xb = -0.155f - 0.14f * std::sin(tilt) - 0.015f * std::cos(tilt) - kGap;
  b.push_back(box(0.03f, 0.08f, 0.14f, at(xb + half_h * std::sin(tilt), 0.14f, half_h * std::cos(tilt), 0.f, 20.f),
                  {235, 205, 35}));
  b.push_back(box(0.07f, 0.07f, 0.18f, at(-0.12f, 0.14f, 0.09f), {190, 40, 165}));
  // A row of touching objects of different heights.
  b.push_back(box(0.08f, 0.08f, 0.12f, at(-0.20f, -0.03f, 0.06f), {30, 175, 195}));
  b.push_back(box(0.10f, 0.07f, 0.06f, at(-0.1095f, -0.025f, 0.03f), {240, 115, 20}));
  b.push_back(can(0.07f, 0.11f, at(-0.024f, -0.03f, 0.055f), {105, 50, 165}));
  b.push_back(box(0.06f, 0.06f, 0.09f, at(0.0415f, -0.03f, 0.045f), {235, 235, 230}));
  // A wide low box, a flat book lying on it (turned 10 degrees) and a small box on the book.
  b.push_back(box(0.18f, 0.14f, 0.05f, at(0.162f, -0.01f, 0.025f), {35, 35, 40}));
  b.push_back(box(0.12f, 0.09f, 0.025f, at(0.16f, -0.01f, 0.05f + kGap + 0.0125f, 10.f), {150, 215, 45}));
  b.push_back(box(0.05f, 0.05f, 0.05f, at(0.15f, -0.01f, 0.075f + 2 * kGap + 0.025f), {240, 140, 180}));
  // Three touching cans behind.
  for (int k = 0; k < 3; ++k) {
    const Rgb8 colors[3] = {{200, 30, 35}, {35, 70, 200}, {140, 140, 150}};
    b.push_back(can(0.066f, 0.12f, at(0.0f + k * (0.066f + kGap), 0.15f, 0.06f), colors[k]));
  }
  return b;
}

// The simulator's camera: 1 m from (0, 0.05, 0), 45 degrees down.
Eigen::Isometry3f world_to_camera() {
  const Eigen::Vector3f target(0.f, 0.05f, 0.f);
  const Eigen::Vector3f position = target + Eigen::Vector3f(0.f, -std::cos(kPi / 4), std::sin(kPi / 4));
  const Eigen::Vector3f z = (target - position).normalized(), x = Eigen::Vector3f::UnitX(), y = z.cross(x);
  Eigen::Matrix3f camera_to_world;
  camera_to_world << x, y, z;
  Eigen::Isometry3f t = Eigen::Isometry3f::Identity();
  t.linear() = camera_to_world.transpose();
  t.translation() = -(camera_to_world.transpose() * position);
  return t;
}

sim::RenderedFrame render(const std::vector<Body>& bodies, std::uint64_t noise_seed) {
  const Eigen::Isometry3f to_camera = world_to_camera();
  sim::Scene scene;
  sim::Plane table;
  table.pose = Pose::from_isometry(to_camera * at(0.f, 0.05f, 0.f));
  table.half_extent_x = 0.9f;
  table.half_extent_y = 0.55f;
  table.color_a = {186, 142, 98};
  table.color_b = {166, 122, 80};
  table.tile_m = 0.10f;
  scene.planes.push_back(table);
  for (std::size_t k = 0; k < bodies.size(); ++k) {
    sim::Primitive p;
    p.kind = bodies[k].kind;
    p.size = bodies[k].size;
    p.pose = Pose::from_isometry(to_camera * bodies[k].world);
    p.face_colors.fill(bodies[k].color);
    p.label = static_cast<std::uint16_t>(k + 1);
    scene.primitives.push_back(p);
  }
  scene.light_direction = to_camera.linear() * Eigen::Vector3f(0.25f, -0.35f, 1.0f).normalized();
  return sim::render_scene(scene, sim::CameraIntrinsics{}, sim::SensorOptions{}, noise_seed);
}

struct PileResult {
  int objects = 0;       // ground-truth objects with voxels
  int found = 0;         // of them, held by one object with IoU >= 0.5
  int spurious = 0;      // objects mostly on the table
  float unassigned = 0;  // share of the objects' voxels in no object
  double ms = 0;         // the first frame's ObjectManager::process (discovery included)
  std::vector<int> missed;
};

PileResult first_frame_objects(const std::vector<Body>& bodies, std::uint64_t noise_seed) {
  // The defaults with discovery's colour cut on (merger.discovery.color_cut, off as shipped: at 35 it split the
  // striped can of `contact`, 99.8 -> 82.2 % over 60 frames); MFOT_PILE_CONFIG: a config of one's own instead.
  const char* overlay = std::getenv("MFOT_PILE_CONFIG");
  YAML::Node colour_cut;
  colour_cut["merger"]["discovery"]["color_cut"] = 35;
  const YAML::Node config =
      overlay != nullptr ? service::load_config_file(overlay) : service::merged_over_defaults(colour_cut);
  const auto preprocess = service::load_preprocess_config(config);
  const auto merger = service::load_merger_config(config);
  const sim::RenderedFrame frame = render(bodies, noise_seed);
  Preprocessor preprocessor(preprocess.preprocessor);
  const SceneCloud& cloud = preprocessor.process(sim::image_view(frame));
  ColoredCloud points;
  points.positions = cloud.positions;
  points.colors = cloud.colors;
  ObjectManager manager(merger.manager, make_object_discovery(merger.manager.discovery));
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<std::int32_t> labels = manager.process(points, cloud.cluster, {}).labels;
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();

  std::map<int, int> truth_size, object_size, object_table;
  std::map<std::pair<int, int>, int> overlap;
  int object_voxels = 0, unassigned = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const int truth =
        frame.labels[static_cast<std::size_t>(cloud.pixel_v[i]) * frame.intrinsics.width + cloud.pixel_u[i]];
    const int label = labels[i];
    if (truth != 0) {
      ++truth_size[truth];
      ++object_voxels;
      if (label == 0) ++unassigned;
    }
    if (label != 0) {
      ++object_size[label];
      if (truth == 0) ++object_table[label];
      if (truth != 0) ++overlap[{truth, label}];
    }
  }
  PileResult r;
  r.ms = ms;
  r.objects = static_cast<int>(truth_size.size());
  for (const auto& [truth, size] : truth_size) {
    double best = 0.0;
    for (const auto& [key, count] : overlap) {
      if (key.first != truth) continue;
      best = std::max(best, static_cast<double>(count) / (size + object_size[key.second] - count));
    }
    if (std::getenv("MFOT_PILE_DEBUG") != nullptr) {
      std::printf("truth %d (%d voxels):", truth, size);
      for (const auto& [key, count] : overlap) {
        if (key.first == truth) std::printf(" obj %d holds %d of its %d", key.second, count, object_size[key.second]);
      }
      std::printf("\n");
    }
    if (best >= 0.5) {
      ++r.found;
    } else {
      r.missed.push_back(truth);
    }
  }
  for (const auto& [label, size] : object_size) r.spurious += 2 * object_table[label] > size ? 1 : 0;
  r.unassigned = object_voxels > 0 ? static_cast<float>(unassigned) / static_cast<float>(object_voxels) : 0.f;
  return r;
}

::testing::Message describe(const PileResult& r) {
  ::testing::Message m;
  m << r.found << " of " << r.objects << " found, " << r.spurious << " spurious, " << 100.f * r.unassigned
    << " % of the objects' voxels in no object, " << r.ms << " ms; missed:";
  for (const int k : r.missed) m << " " << k;
  return m;
}

// Convexity alone (merger.discovery.color_cut 0) found 7, 8 and 7 of the 15: the run of boxes leaving the image,
// the leaning box and its support, a can and the box it touches, and the three cans behind each came out as one.
TEST(PileDiscovery, ObjectsOfATouchingPileAreFound) {
  const std::vector<Body> bodies = pile();
  int found = 0, objects = 0;
  for (const std::uint64_t seed : {1u, 2u, 3u}) {
    const PileResult r = first_frame_objects(bodies, seed);
    SCOPED_TRACE(describe(r) << " (noise seed " << seed << ")");
    std::printf("[pile] seed %llu: %s\n", static_cast<unsigned long long>(seed), describe(r).GetString().c_str());
    EXPECT_EQ(r.objects, static_cast<int>(bodies.size()));
    EXPECT_GE(r.found, r.objects - 2);
    EXPECT_EQ(r.spurious, 0);
    EXPECT_LE(r.unassigned, 0.02f);
    found += r.found;
    objects += r.objects;
  }
  EXPECT_GE(found, 0.95 * objects) << found << " of " << objects;
}

}  // namespace
}  // namespace mfot
