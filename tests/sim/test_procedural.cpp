// The procedural scenario: determinism per seed, plausibility of the generated scenes (objects on
// or above the table, no interpenetration, every object seen, labels on the posed surfaces, the
// camera on the table), and every motion class produced and behaving as named.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "mfot/sim/simulator.hpp"

namespace mfot::sim {
namespace {

constexpr float kPi = 3.14159265f;
constexpr float kDeg = kPi / 180.0f;

SimulatorOptions procedural(std::uint64_t seed, bool noise = true) {
  SimulatorOptions o;
  o.scenario.name = "procedural";
  o.scenario.seed = seed;
  o.sensor.noise = noise;
  return o;
}

// World pose (body -> world) of every body at frame.
std::vector<Eigen::Isometry3f> world_poses(const Simulator& sim, int frame) {
  const Eigen::Isometry3f camera_to_world = sim.world_to_camera().isometry().inverse();
  std::vector<Eigen::Isometry3f> out;
  for (const GroundTruthPose& p : sim.poses(frame)) out.push_back(camera_to_world * p.pose.isometry());
  return out;
}

// Index into bodies() / poses() of the body with label id.
int index_of(const Simulator& sim, int id) {
  for (std::size_t i = 0; i < sim.bodies().size(); ++i) {
    if (sim.bodies()[i].id == id) return static_cast<int>(i);
  }
  return -1;
}

// Whether world point p lies inside primitive prim (posed by body_to_world) grown by margin
// (negative: shrunk).
bool inside(const Primitive& prim, const Eigen::Isometry3f& body_to_world, const Eigen::Vector3f& p, float margin) {
  const Eigen::Vector3f q = (body_to_world * prim.pose.isometry()).inverse() * p;
  const Eigen::Vector3f half = 0.5f * prim.size;
  if (prim.kind == PrimitiveKind::box) return ((q.cwiseAbs() - half).array() < margin).all();
  return std::hypot(q.x(), q.y()) < half.x() + margin && std::abs(q.z()) < half.z() + margin;
}

// Sample points of a primitive's volume (a 5 x 5 x 5 grid through it; cylinders: inside the
// inscribed square prism), world frame.
std::vector<Eigen::Vector3f> volume_samples(const Primitive& prim, const Eigen::Isometry3f& body_to_world) {
  std::vector<Eigen::Vector3f> out;
  const Eigen::Isometry3f to_world = body_to_world * prim.pose.isometry();
  for (int i = 0; i < 5; ++i) {
    for (int j = 0; j < 5; ++j) {
      for (int k = 0; k < 5; ++k) {
        Eigen::Vector3f f(i / 4.0f - 0.5f, j / 4.0f - 0.5f, k / 4.0f - 0.5f);
        if (prim.kind == PrimitiveKind::cylinder) f.head<2>() *= 0.7f;
        out.push_back(to_world * f.cwiseProduct(prim.size));
      }
    }
  }
  return out;
}

// Lowest world z of a body's primitives (their bounding boxes' corners: exact for boxes and for
// upright cylinders, conservative for tilted ones).
float lowest_point(const BodyInfo& body, const Eigen::Isometry3f& body_to_world) {
  float low = 1e9f;
  for (const Primitive& prim : body.primitives) {
    const Eigen::Isometry3f to_world = body_to_world * prim.pose.isometry();
    for (int c = 0; c < 8; ++c) {
      const Eigen::Vector3f corner(c & 1 ? 0.5f : -0.5f, c & 2 ? 0.5f : -0.5f, c & 4 ? 0.5f : -0.5f);
      low = std::min(low, (to_world * corner.cwiseProduct(prim.size)).z());
    }
  }
  return low;
}

float angle_between(const Eigen::Matrix3f& a, const Eigen::Matrix3f& b) {
  return Eigen::AngleAxisf(a.transpose() * b).angle();
}

// The first seed in [1, 80] whose scene has the given motion class (0: none).
std::uint64_t seed_with_motion(const std::string& motion) {
  for (std::uint64_t seed = 1; seed <= 80; ++seed) {
    if (Simulator(procedural(seed)).summary().motion == motion) return seed;
  }
  return 0;
}

TEST(Procedural, SameSeedGivesIdenticalFramesAndGroundTruthOtherSeedsDiffer) {
  const Simulator a(procedural(7)), b(procedural(7));
  ASSERT_EQ(a.num_frames(), b.num_frames());
  EXPECT_EQ(a.summary().yaml(), b.summary().yaml());
  for (const int frame : {0, a.num_frames() / 2, a.num_frames() - 1}) {
    const RenderedFrame fa = a.render(frame), fb = b.render(frame);
    EXPECT_EQ(fa.depth_mm, fb.depth_mm) << frame;
    EXPECT_EQ(fa.color, fb.color) << frame;
    EXPECT_EQ(fa.labels, fb.labels) << frame;
    ASSERT_EQ(fa.poses.size(), fb.poses.size());
    for (std::size_t i = 0; i < fa.poses.size(); ++i) {
      EXPECT_EQ(fa.poses[i].pose.translation, fb.poses[i].pose.translation);
      EXPECT_EQ(fa.poses[i].pose.rotation.coeffs(), fb.poses[i].pose.rotation.coeffs());
    }
  }
  const Simulator c(procedural(8));
  EXPECT_NE(a.summary().yaml(), c.summary().yaml());
  const RenderedFrame f7 = a.render(0), f8 = c.render(0);
  int differing = 0;
  for (std::size_t i = 0; i < f7.labels.size(); ++i) differing += f7.labels[i] != f8.labels[i];
  EXPECT_GT(differing, 1000);
}

TEST(Procedural, SummaryNamesTheSceneInTheSourceNameAndYaml) {
  const Simulator sim(procedural(5));
  const SceneSummary& s = sim.summary();
  EXPECT_EQ(s.scenario, "procedural");
  EXPECT_EQ(s.seed, 5u);
  int objects = 0;
  for (const BodyInfo& body : sim.bodies()) objects += body.is_hand ? 0 : 1;
  EXPECT_EQ(static_cast<int>(s.objects.size()), objects);
  EXPECT_EQ(s.source_name().rfind("sim:procedural:5:" + s.motion + ":", 0), 0u) << s.source_name();
  EXPECT_NE(s.yaml().find("motion: " + s.motion + "\n"), std::string::npos);
  EXPECT_NE(s.yaml().find("shape: " + s.objects.front().shape), std::string::npos);
  SimulatorOptions stack;
  EXPECT_EQ(Simulator(stack).summary().source_name(), "sim:stack");
  EXPECT_EQ(Simulator(stack).summary().yaml(), "scenario: stack\nseed: 1\n");
}

// Every class of the generator shows up in a small range of seeds.
TEST(Procedural, EveryMotionMoverShapeAndTextureAppearsInSeedsOneToSixty) {
  std::set<std::string> motions, movers, shapes, textures;
  std::map<std::string, int> counts;
  for (std::uint64_t seed = 1; seed <= 60; ++seed) {
    const Simulator sim(procedural(seed));
    const SceneSummary& s = sim.summary();
    motions.insert(s.motion);
    movers.insert(s.mover);
    for (const auto& o : s.objects) shapes.insert(o.shape), textures.insert(o.texture);
    EXPECT_GE(s.objects.size(), 1u);
    EXPECT_LE(s.objects.size(), 20u);
    counts[s.objects.size() > 5 ? "many" : "few"] += 1;
    counts["mover " + s.mover] += 1;
  }
  for (const std::string& m : procedural_motion_names()) EXPECT_TRUE(motions.count(m)) << m;
  EXPECT_EQ(motions.size(), procedural_motion_names().size());
  EXPECT_EQ(movers, (std::set<std::string>{"hand", "gripper", "none"}));
  EXPECT_EQ(shapes, (std::set<std::string>{"box", "can", "bottle", "mug"}));
  EXPECT_EQ(textures, (std::set<std::string>{"plain", "stripes", "label", "checker"}));
  EXPECT_GT(counts["many"], 3);
  EXPECT_GT(counts["few"], 20);
  // A visible mover is not traded for visibility at frame 0 (the layout retries): it waits out of
  // the image, so seeds keep their drawn mover (none in about 4 of 9 scenes).
  EXPECT_LT(counts["mover none"], 60 / 2 + 6);
  EXPECT_GT(counts["mover gripper"], 60 / 4);
}

// A can or bottle carries its symmetry axis (for the evaluator's axis-only rotation) only when plain: its
// stripes, label or checker show its turns about the axis, so the ground truth asks for its full rotation.
TEST(Procedural, OnlyPlainCansAndBottlesKeepTheirSymmetryAxis) {
  std::map<std::string, int> seen;
  for (std::uint64_t seed = 1; seed <= 60; ++seed) {
    const Simulator sim(procedural(seed, false));
    for (const SceneSummary::Object& o : sim.summary().objects) {
      const BodyInfo& body = sim.bodies()[static_cast<std::size_t>(index_of(sim, o.id))];
      const bool turned_shape = o.shape == "can" || o.shape == "bottle";
      const bool expect_axis = turned_shape && o.texture == "plain";
      EXPECT_EQ(!body.symmetry_axis.isZero(), expect_axis)
          << "seed " << seed << " id " << o.id << " " << o.shape << " " << o.texture;
      if (expect_axis) {
        EXPECT_TRUE(body.symmetry_axis.isApprox(Eigen::Vector3f::UnitZ()));
      }
      for (const GroundTruthPose& p : sim.poses(0)) {
        if (p.id == o.id) {
          EXPECT_EQ(p.symmetry_axis, body.symmetry_axis);
        }
      }
      if (turned_shape) seen[o.texture == "plain" ? "plain" : "textured"] += 1;
    }
  }
  EXPECT_GT(seen["plain"], 0);
  EXPECT_GT(seen["textured"], 0);
}

// Objects stay on or above the table, never overlap, are each seen in some frame, and the labels
// of the rendered pixels lie on the surfaces of the bodies that ground truth poses there; the
// camera looks at the table from a varying height.
TEST(Procedural, ScenesArePlausible) {
  std::set<int> heights_cm;
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const Simulator sim(procedural(seed, false));
    const std::vector<BodyInfo>& bodies = sim.bodies();
    const SceneSummary& s = sim.summary();

    // Camera: its optical axis meets the table top inside the table, from 0.4-1.2 m above it.
    const Eigen::Isometry3f camera_to_world = sim.world_to_camera().isometry().inverse();
    const Eigen::Vector3f eye = camera_to_world.translation(), ray = camera_to_world.linear().col(2);
    ASSERT_LT(ray.z(), 0.0f);
    const Eigen::Vector3f hit = eye - (eye.z() / ray.z()) * ray;
    EXPECT_LT(std::abs(hit.x()), 0.3f);
    EXPECT_GT(hit.y(), -0.1f);
    EXPECT_LT(hit.y(), 0.3f);
    EXPECT_GT(eye.z(), 0.4f);
    EXPECT_LT(eye.z(), 1.2f);
    EXPECT_NEAR(eye.z(), s.camera_height_m, 1e-3f);
    heights_cm.insert(static_cast<int>(eye.z() * 10.0f));

    // On or above the table and apart, at every 5th frame (frame 0 included).
    for (int frame = 0; frame < sim.num_frames(); frame += 5) {
      const auto poses = world_poses(sim, frame);
      for (std::size_t i = 0; i < bodies.size(); ++i) {
        if (bodies[i].is_hand) continue;
        ASSERT_GT(lowest_point(bodies[i], poses[i]), -0.0005f) << "object " << bodies[i].id << " frame " << frame;
        for (std::size_t j = 0; j < bodies.size(); ++j) {
          if (j == i || bodies[j].is_hand) continue;
          for (const Primitive& a : bodies[i].primitives) {
            for (const Eigen::Vector3f& p : volume_samples(a, poses[i])) {
              for (const Primitive& b : bodies[j].primitives) {
                ASSERT_FALSE(inside(b, poses[j], p, -0.0003f))
                    << "objects " << bodies[i].id << " and " << bodies[j].id << " overlap at frame " << frame;
              }
            }
          }
        }
      }
    }

    // Labels: every measured pixel of an object lies on (within 3 mm of) one of its primitives as
    // posed by the ground truth; every object is seen in some frame.
    std::map<int, int> seen;
    for (int frame = 0; frame < sim.num_frames(); frame += 30) {
      const RenderedFrame f = sim.render(frame);
      const CameraIntrinsics& k = f.intrinsics;
      for (int v = 0; v < k.height; v += 2) {
        for (int u = 0; u < k.width; u += 2) {
          const std::size_t i = static_cast<std::size_t>(v) * k.width + u;
          const int label = f.labels[i];
          if (label == 0 || f.depth_mm[i] == 0) continue;
          const float z = f.depth_mm[i] * 0.001f;
          const Eigen::Vector3f p((u - k.cx) / k.fx * z, (v - k.cy) / k.fy * z, z);
          const int b = index_of(sim, label);
          ASSERT_GE(b, 0) << "label " << label;
          const Eigen::Isometry3f pose = f.poses[b].pose.isometry();
          const bool on_body = std::any_of(bodies[b].primitives.begin(), bodies[b].primitives.end(),
                                           [&](const Primitive& prim) { return inside(prim, pose, p, 0.003f); });
          ASSERT_TRUE(on_body) << "pixel (" << u << ", " << v << ") labelled " << label << " at frame " << frame;
          ++seen[label];
        }
      }
    }
    for (const auto& o : s.objects) EXPECT_GT(seen[o.id], 20) << "object " << o.id << " never seen";
  }
  EXPECT_GT(heights_cm.size(), 3u);  // the camera height varies with the seed
}

// Over whole scenes of 40 seeds, movers included: speeds within 0.3 m/s and 190 deg/s, nothing
// below the table top, no two bodies interpenetrating (every 3rd frame).
TEST(Procedural, MotionIsPhysicallyPlausibleOverSeeds) {
  for (std::uint64_t seed = 1; seed <= 40; ++seed) {
    const Simulator sim(procedural(seed));
    const auto& bodies = sim.bodies();
    std::vector<Eigen::Isometry3f> prev;
    for (int frame = 0; frame < sim.num_frames(); ++frame) {
      const auto world = world_poses(sim, frame);
      for (std::size_t b = 0; b < bodies.size() && !prev.empty(); ++b) {
        const float speed = (world[b].translation() - prev[b].translation()).norm() * 30.0f;
        const float turn = angle_between(prev[b].linear(), world[b].linear()) * 30.0f;
        ASSERT_LE(speed, 0.3f) << "seed " << seed << " frame " << frame << " body " << bodies[b].id;
        ASSERT_LE(turn, 190.0f * kDeg) << "seed " << seed << " frame " << frame << " body " << bodies[b].id;
      }
      prev = world;
      if (frame % 3 != 0) continue;
      for (std::size_t a = 0; a < bodies.size(); ++a) {
        for (const Primitive& prim : bodies[a].primitives) {
          const auto samples = volume_samples(prim, world[a]);
          for (const Eigen::Vector3f& p : samples) {
            ASSERT_GT(p.z(), -0.001f) << sim.summary().source_name() << " mover " << sim.summary().mover << " frame "
                                      << frame << " body " << bodies[a].id << " below the table";
          }
          for (std::size_t b = 0; b < bodies.size(); ++b) {
            if (b == a) continue;
            for (const Primitive& other : bodies[b].primitives) {
              for (const Eigen::Vector3f& p : samples) {
                ASSERT_FALSE(inside(other, world[b], p, -0.001f)) << "seed " << seed << " frame " << frame << ": body "
                                                                  << bodies[a].id << " inside body " << bodies[b].id;
              }
            }
          }
        }
      }
    }
  }
}

class MotionClass : public ::testing::TestWithParam<std::string> {};

// The moved objects' world poses over the whole scene.
struct Track {
  std::vector<Eigen::Isometry3f> poses;
};

std::map<int, Track> tracks_of(const Simulator& sim) {
  std::map<int, Track> out;
  for (int frame = 0; frame < sim.num_frames(); ++frame) {
    const auto poses = world_poses(sim, frame);
    for (std::size_t i = 0; i < poses.size(); ++i) out[sim.bodies()[i].id].poses.push_back(poses[i]);
  }
  return out;
}

// Sum of the per-frame turn angles (radians).
float turned(const Track& t) {
  float sum = 0.0f;
  for (std::size_t k = 1; k < t.poses.size(); ++k) sum += angle_between(t.poses[k - 1].linear(), t.poses[k].linear());
  return sum;
}

float travelled(const Track& t) {
  return (t.poses.back().translation() - t.poses.front().translation()).head<2>().norm();
}

float height_range(const Track& t) {
  float lo = 1e9f, hi = -1e9f;
  for (const auto& p : t.poses) lo = std::min(lo, p.translation().z()), hi = std::max(hi, p.translation().z());
  return hi - lo;
}

TEST_P(MotionClass, BehavesAsNamed) {
  const std::string motion = GetParam();
  const std::uint64_t seed = seed_with_motion(motion);
  ASSERT_GT(seed, 0u) << "no seed in 1-80 gives " << motion;
  SCOPED_TRACE("seed " + std::to_string(seed));
  const Simulator sim(procedural(seed));
  const SceneSummary& s = sim.summary();
  const auto tracks = tracks_of(sim);
  std::vector<int> moved;
  for (const auto& o : s.objects) {
    if (o.moved) moved.push_back(o.id);
  }
  ASSERT_FALSE(moved.empty());
  const Track& main = tracks.at(moved.front());
  // Objects that are not moved stay where they are (a stack's base included).
  for (const auto& o : s.objects) {
    if (o.moved) continue;
    const Track& t = tracks.at(o.id);
    EXPECT_LT((t.poses.back().translation() - t.poses.front().translation()).norm(), 1e-5f) << "object " << o.id;
  }
  // A visible mover comes into the scene and holds the object while it moves.
  if (s.mover != "none") {
    const auto hand =
        std::find_if(sim.bodies().begin(), sim.bodies().end(), [](const BodyInfo& b) { return b.is_hand; });
    ASSERT_NE(hand, sim.bodies().end());
    const Track& h = tracks.at(hand->id);
    const std::size_t mid = h.poses.size() / 2;
    const Eigen::Isometry3f grip = main.poses[mid].inverse() * h.poses[mid];
    for (std::size_t k = 0; k < h.poses.size(); ++k) {
      const bool moving = k > 0 && (main.poses[k].translation() - main.poses[k - 1].translation()).norm() +
                                           angle_between(main.poses[k].linear(), main.poses[k - 1].linear()) >
                                       1e-4f;
      if (!moving) continue;
      EXPECT_LT(((main.poses[k] * grip).translation() - h.poses[k].translation()).norm(), 1e-3f) << "frame " << k;
    }
  }
  const Eigen::Vector3f up = Eigen::Vector3f::UnitZ();
  if (motion == "slide") {
    EXPECT_GT(travelled(main), 0.05f);
    EXPECT_LT(height_range(main), 1e-4f);
    for (const auto& p : main.poses) EXPECT_GT((p.linear() * up).z(), 0.99999f);
  } else if (motion == "push") {
    ASSERT_GE(moved.size(), 2u);
    // Each member of the chain starts moving later than the one before it, and all move on the table.
    int previous_start = -1;
    for (const int id : moved) {
      const Track& t = tracks.at(id);
      EXPECT_GT(travelled(t), 0.03f) << "object " << id;
      EXPECT_LT(height_range(t), 1e-4f) << "object " << id;
      int start = 0;
      while (start + 1 < static_cast<int>(t.poses.size()) &&
             (t.poses[start + 1].translation() - t.poses[0].translation()).norm() < 1e-5f) {
        ++start;
      }
      EXPECT_GT(start, previous_start) << "object " << id;
      previous_start = start;
    }
    // At the end the pusher and the first pushed object are closer than at the start (in contact).
    const Track& pushed = tracks.at(moved[1]);
    EXPECT_LT((main.poses.back().translation() - pushed.poses.back().translation()).norm(),
              (main.poses.front().translation() - pushed.poses.front().translation()).norm() - 0.03f);
  } else if (motion == "spin") {
    const Eigen::Vector3f axis = s.spin_axis;
    ASSERT_NEAR(axis.norm(), 1.0f, 1e-4f);
    const Eigen::Vector3f w0 = main.poses.front().linear() * axis;
    for (const auto& p : main.poses) EXPECT_GT((p.linear() * axis).dot(w0), std::cos(0.5f * kDeg));
    EXPECT_GT(turned(main), 0.95f * std::abs(s.spin_angle_rad));
    EXPECT_GT(std::abs(s.spin_angle_rad), 2.0f * kPi * 0.99f);
    if (s.spin_on_table) {
      EXPECT_LT(height_range(main), 1e-4f);
    }
  } else if (motion == "tilt") {
    float most = 0.0f;
    for (const auto& p : main.poses) most = std::max(most, std::acos(std::clamp((p.linear() * up).z(), -1.0f, 1.0f)));
    EXPECT_GT(most, 60.0f * kDeg);
    EXPECT_LT(angle_between(main.poses.front().linear(), main.poses.back().linear()), 0.1f * kDeg);
    EXPECT_LT((main.poses.front().translation() - main.poses.back().translation()).norm(), 1e-4f);
  } else if (motion == "stack") {
    ASSERT_GT(s.stack_base_id, 0);
    const int b = index_of(sim, s.stack_base_id), m = index_of(sim, moved.front());
    const Eigen::Isometry3f base = tracks.at(s.stack_base_id).poses.back();
    const float base_top = base.translation().z() + 0.5f * sim.bodies()[b].primitives.front().size.z();
    EXPECT_NEAR(lowest_point(sim.bodies()[m], main.poses.back()), base_top, 1e-3f);
    EXPECT_LT((main.poses.back().translation() - base.translation()).head<2>().norm(), 1e-4f);
    EXPECT_GT(travelled(main), 0.1f);
  } else if (motion == "tumble") {
    EXPECT_GT(turned(main), 1.9f * 2.0f * kPi);
    const int m = index_of(sim, moved.front());
    float lowest_in_air = 1e9f;
    for (std::size_t k = main.poses.size() / 3; k < 2 * main.poses.size() / 3; ++k) {
      if (angle_between(main.poses[k].linear(), main.poses[k - 1].linear()) > 0.5f * kDeg) {
        lowest_in_air = std::min(lowest_in_air, lowest_point(sim.bodies()[m], main.poses[k]));
      }
    }
    EXPECT_GT(lowest_in_air, 0.02f);
    EXPECT_NEAR(lowest_point(sim.bodies()[m], main.poses.back()), 0.0f, 1e-3f);  // landed on a face
  }
}

INSTANTIATE_TEST_SUITE_P(Procedural, MotionClass, ::testing::ValuesIn(procedural_motion_names()),
                         [](const ::testing::TestParamInfo<std::string>& info) { return info.param; });

}  // namespace
}  // namespace mfot::sim
