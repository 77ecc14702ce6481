// Scenarios and the Simulator: determinism, frame counts, separation and visibility at frame 0,
// physically plausible motion (speed limits, no interpenetration, rigid grasps).

#include "mfot/sim/simulator.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

namespace mfot::sim {
namespace {

SimulatorOptions options_for(const std::string& name, std::uint64_t seed = 1) {
  SimulatorOptions o;
  o.scenario.name = name;
  o.scenario.seed = seed;
  return o;
}

// Whether world point p lies inside primitive prim (posed by body_to_world) shrunk by margin.
bool inside(const Primitive& prim, const Eigen::Isometry3f& body_to_world, const Eigen::Vector3f& p, float margin) {
  const Eigen::Vector3f q = (body_to_world * prim.pose.isometry()).inverse() * p;
  const Eigen::Vector3f half = 0.5f * prim.size;
  if (prim.kind == PrimitiveKind::box) return ((q.cwiseAbs() - half).array() < -margin).all();
  return std::hypot(q.x(), q.y()) < half.x() - margin && std::abs(q.z()) < half.z() - margin;
}

// Sample points of a primitive's volume (a 5 x 5 x 5 grid through it), world frame.
std::vector<Eigen::Vector3f> volume_samples(const Primitive& prim, const Eigen::Isometry3f& body_to_world) {
  std::vector<Eigen::Vector3f> out;
  const Eigen::Isometry3f to_world = body_to_world * prim.pose.isometry();
  for (int i = 0; i < 5; ++i) {
    for (int j = 0; j < 5; ++j) {
      for (int k = 0; k < 5; ++k) {
        Eigen::Vector3f f(i / 4.0f - 0.5f, j / 4.0f - 0.5f, k / 4.0f - 0.5f);
        if (prim.kind == PrimitiveKind::cylinder) f.head<2>() *= 0.7f;  // inside the inscribed square
        out.push_back(to_world * f.cwiseProduct(prim.size));
      }
    }
  }
  return out;
}

TEST(Simulator, ScenarioNamesAndFrameCounts) {
  const auto names = scenario_names();
  ASSERT_EQ(names.size(), 6u);
  for (const std::string& name : names) {
    const Simulator sim(options_for(name));
    EXPECT_GE(sim.num_frames(), 300) << name;
    EXPECT_LE(sim.num_frames(), 900) << name;
    EXPECT_DOUBLE_EQ(sim.fps(), 30.0);
  }
  SimulatorOptions o = options_for("static");
  o.scenario.num_frames = 17;
  EXPECT_EQ(Simulator(o).num_frames(), 17);
  EXPECT_THROW(Simulator(o).render(17), std::out_of_range);
}

TEST(Simulator, SameOptionsGiveIdenticalFramesInAnyOrder) {
  const Simulator a(options_for("stack", 5));
  const Simulator b(options_for("stack", 5));
  const RenderedFrame a120 = a.render(120);
  const RenderedFrame a30 = a.render(30);
  const RenderedFrame b30 = b.render(30);
  const RenderedFrame b120 = b.render(120);
  EXPECT_EQ(a30.depth_mm, b30.depth_mm);
  EXPECT_EQ(a30.color, b30.color);
  EXPECT_EQ(a30.labels, b30.labels);
  EXPECT_EQ(a120.depth_mm, b120.depth_mm);
  EXPECT_EQ(a120.index, 120);
  EXPECT_DOUBLE_EQ(a120.time_s, 4.0);

  const RenderedFrame c30 = Simulator(options_for("stack", 6)).render(30);
  int differing = 0;
  for (std::size_t i = 0; i < c30.depth_mm.size(); ++i) differing += c30.depth_mm[i] != a30.depth_mm[i];
  EXPECT_GT(differing, static_cast<int>(c30.depth_mm.size() / 4));
}

TEST(Simulator, RandomScenarioFollowsItsOptions) {
  SimulatorOptions o = options_for("random", 3);
  o.scenario.num_objects = 5;
  o.scenario.occlusion = 0.0f;
  const Simulator sim(o);
  EXPECT_EQ(sim.num_frames(), 600);
  int objects = 0, hands = 0;
  for (const BodyInfo& body : sim.bodies()) (body.is_hand ? hands : objects) += 1;
  EXPECT_EQ(objects, 5);
  EXPECT_EQ(hands, 0);

  o.scenario.occlusion = 0.8f;
  const Simulator with_hands(o);
  EXPECT_EQ(with_hands.poses(0).size(), 7u);
  // Hands pass over the scene: some frame shows a hand.
  bool hand_seen = false;
  for (int i = 0; i < with_hands.num_frames() && !hand_seen; i += 60) {
    const RenderedFrame f = with_hands.render(i);
    hand_seen = std::count_if(f.labels.begin(), f.labels.end(), [](std::uint16_t l) { return l > 100; }) > 500;
  }
  EXPECT_TRUE(hand_seen);

  const Simulator other(options_for("random", 4));
  EXPECT_FALSE(other.poses(0)[0].pose.translation.isApprox(Simulator(options_for("random", 3)).poses(0)[0].pose.translation));
}

// Frame 0 of every scenario: every object is visible, and objects (and hands) are pairwise
// separated by at least 2 cm in the measured point cloud.
TEST(Simulator, ObjectsSeparatedAndVisibleAtFrameZero) {
  std::vector<SimulatorOptions> cases;
  for (const std::string& name : scenario_names()) cases.push_back(options_for(name));
  for (std::uint64_t seed = 10; seed < 13; ++seed) {
    SimulatorOptions o = options_for("random", seed);
    o.scenario.num_objects = 6;
    cases.push_back(o);
  }
  for (const SimulatorOptions& o : cases) {
    const Simulator sim(o);
    const RenderedFrame f = sim.render(0);
    const CameraIntrinsics& cam = f.intrinsics;
    std::map<int, std::vector<Eigen::Vector3f>> points;
    for (int v = 0; v < cam.height; ++v) {
      for (int u = 0; u < cam.width; ++u) {
        const std::size_t i = static_cast<std::size_t>(v) * cam.width + u;
        if (f.depth_mm[i] == 0 || f.labels[i] == 0) continue;
        const float z = 0.001f * f.depth_mm[i];
        points[f.labels[i]].emplace_back((u - cam.cx) * z / cam.fx, (v - cam.cy) * z / cam.fy, z);
      }
    }
    for (const GroundTruthPose& p : f.poses) {
      if (!p.is_hand) {
        EXPECT_GE(points[p.id].size(), 200u) << o.scenario.name << " object " << p.id;
      }
    }
    if (o.scenario.name == "apart") continue;  // its objects start stacked and touching on purpose
    for (auto a = points.begin(); a != points.end(); ++a) {
      for (auto b = std::next(a); b != points.end(); ++b) {
        float closest = 1e9f;
        for (std::size_t i = 0; i < a->second.size(); i += 3) {
          for (std::size_t j = 0; j < b->second.size(); j += 3) {
            closest = std::min(closest, (a->second[i] - b->second[j]).squaredNorm());
          }
        }
        EXPECT_GT(std::sqrt(closest), 0.02f) << o.scenario.name << " labels " << a->first << ", " << b->first;
      }
    }
  }
}

// Over whole scenarios: speeds within hand-manipulation limits, nothing below the table top, no
// two bodies interpenetrating, and a carried object keeps its pose relative to its hand.
TEST(Simulator, MotionIsPhysicallyPlausible) {
  for (const std::string& name : scenario_names()) {
    SimulatorOptions o = options_for(name, 2);
    o.scenario.occlusion = 0.6f;
    const Simulator sim(o);
    const Eigen::Isometry3f camera_to_world = sim.world_to_camera().isometry().inverse();
    const auto& bodies = sim.bodies();
    std::vector<Eigen::Isometry3f> prev;
    for (int frame = 0; frame < sim.num_frames(); ++frame) {
      const auto poses = sim.poses(frame);
      ASSERT_EQ(poses.size(), bodies.size());
      std::vector<Eigen::Isometry3f> world;
      for (const GroundTruthPose& p : poses) world.push_back(camera_to_world * p.pose.isometry());
      if (!prev.empty()) {
        for (std::size_t b = 0; b < bodies.size(); ++b) {
          const float speed = (world[b].translation() - prev[b].translation()).norm() * 30.0f;
          const float turn = Eigen::AngleAxisf(prev[b].rotation().transpose() * world[b].rotation()).angle() * 30.0f;
          ASSERT_LE(speed, 0.3f) << name << " frame " << frame << " body " << bodies[b].id;
          ASSERT_LE(turn, 90.0f * 3.14159265f / 180.0f) << name << " frame " << frame << " body " << bodies[b].id;
          // An object that moves is carried by a hand (random: or slides) rigidly.
          const bool moved = !world[b].isApprox(prev[b], 1e-5f);
          if (moved && !bodies[b].is_hand && name != "random") {
            bool rigid_with_a_hand = false;
            for (std::size_t h = 0; h < bodies.size(); ++h) {
              if (!bodies[h].is_hand) continue;
              const Eigen::Isometry3f now = world[h].inverse() * world[b], before = prev[h].inverse() * prev[b];
              rigid_with_a_hand |= now.isApprox(before, 1e-4f);
            }
            EXPECT_TRUE(rigid_with_a_hand) << name << " frame " << frame << " object " << bodies[b].id;
          }
        }
      }
      prev = world;
      if (frame % 3 != 0) continue;
      for (std::size_t a = 0; a < bodies.size(); ++a) {
        for (const Primitive& prim : bodies[a].primitives) {
          const auto samples = volume_samples(prim, world[a]);
          for (const Eigen::Vector3f& s : samples) {
            ASSERT_GT(s.z(), -0.001f) << name << " frame " << frame << " body " << bodies[a].id << " below the table";
          }
          for (std::size_t b = 0; b < bodies.size(); ++b) {
            if (b == a) continue;
            for (const Primitive& other : bodies[b].primitives) {
              for (const Eigen::Vector3f& s : samples) {
                ASSERT_FALSE(inside(other, world[b], s, 0.001f))
                    << name << " frame " << frame << ": body " << bodies[a].id << " inside body " << bodies[b].id;
              }
            }
          }
        }
      }
    }
  }
}

TEST(Simulator, StackScenarioStacksAndUnstacks) {
  const Simulator sim(options_for("stack"));
  const Eigen::Isometry3f camera_to_world = sim.world_to_camera().isometry().inverse();
  auto world_of = [&](int frame, int id) {
    for (const GroundTruthPose& p : sim.poses(frame)) {
      if (p.id == id) return Eigen::Isometry3f(camera_to_world * p.pose.isometry());
    }
    throw std::logic_error("no such body");
  };
  const float top_half = 0.5f * sim.bodies()[0].primitives[0].size.z();
  const float base_height = sim.bodies()[1].primitives[0].size.z();
  bool stacked = false;
  for (int frame = 0; frame < sim.num_frames(); frame += 10) {
    const Eigen::Vector3f top = world_of(frame, 1).translation(), base = world_of(frame, 2).translation();
    stacked |= std::abs(top.z() - (base_height + top_half)) < 1e-4f && (top.head<2>() - base.head<2>()).norm() < 0.01f;
  }
  EXPECT_TRUE(stacked);
  const Eigen::Vector3f end = world_of(sim.num_frames() - 1, 1).translation();
  EXPECT_NEAR(end.z(), top_half, 1e-4f);  // back on the table
}

// The random scenario holds up to 16 objects (12 for the several-hosts benchmark), none touching.
TEST(Simulator, ACrowdedRandomTableHoldsTwelveObjectsApart) {
  SimulatorOptions o = options_for("random", 5);
  o.scenario.num_objects = 12;
  o.scenario.num_frames = 3;
  const Simulator sim(o);
  const Eigen::Isometry3f camera_to_world = sim.world_to_camera().isometry().inverse();
  std::vector<Eigen::Vector3f> centres;
  for (std::size_t b = 0; b < sim.bodies().size(); ++b) {
    if (!sim.bodies()[b].is_hand) centres.push_back(camera_to_world * sim.poses(0)[b].pose.translation);
  }
  ASSERT_EQ(centres.size(), 12u);
  for (std::size_t a = 0; a < centres.size(); ++a) {
    for (std::size_t b = a + 1; b < centres.size(); ++b) EXPECT_GT((centres[a] - centres[b]).head<2>().norm(), 0.05f);
  }
}

TEST(Simulator, InvalidOptionsThrow) {
  SimulatorOptions o;
  o.scenario.name = "juggle";
  EXPECT_THROW(Simulator{o}, std::invalid_argument);
  o = SimulatorOptions{};
  o.scenario.speed = 0.5f;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o = SimulatorOptions{};
  o.scenario.num_objects = 17;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o = SimulatorOptions{};
  o.sensor.color_sigma = -1.0f;
  EXPECT_THROW(o.validate(), std::invalid_argument);
}

}  // namespace
}  // namespace mfot::sim

namespace mfot::sim {
namespace {

TEST(Simulator, CansCarryTheirSymmetryAxisIntoTheGroundTruth) {
  const Simulator sim(options_for("stack"));
  int cans = 0;
  for (const GroundTruthPose& p : sim.poses(0)) {
    if (p.id == 3) {  // stack's striped can
      EXPECT_EQ(p.symmetry_axis, Eigen::Vector3f::UnitZ());
      ++cans;
    } else {
      EXPECT_EQ(p.symmetry_axis, Eigen::Vector3f::Zero()) << "body " << p.id;
    }
  }
  EXPECT_EQ(cans, 1);
}

}  // namespace
}  // namespace mfot::sim
