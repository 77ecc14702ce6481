// Scenarios and the Simulator: determinism, frame counts, separation and visibility at frame 0,
// physically plausible motion (speed limits, no interpenetration, rigid grasps).

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

#include "mfot/sim/simulator.hpp"

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

// World pose of every body at frame.
std::vector<Eigen::Isometry3f> world_poses(const Simulator& sim, int frame) {
  const Eigen::Isometry3f camera_to_world = sim.world_to_camera().isometry().inverse();
  std::vector<Eigen::Isometry3f> out;
  for (const GroundTruthPose& p : sim.poses(frame)) out.push_back(camera_to_world * p.pose.isometry());
  return out;
}

constexpr float kPi = 3.14159265f;
constexpr float kDeg = kPi / 180.0f;

// Objects of these scenarios move without hands: they slide on the table or float above it.
// (procedural: with or without a visible mover; test_procedural.cpp checks its grip.)
bool hands_free(const std::string& name) {
  return name == "random" || name == "spin" || name == "tumble" || name == "slide" || name == "cross" ||
         name == "procedural";
}
// Peak turn rates: hand manipulation at most 90 deg/s; spin and tumble turn objects at up to
// 180 deg/s by design (the margin covers the per-frame measurement).
constexpr float kHandTurnLimit = 90.0f * kDeg;           // rad/s
constexpr float kFastRotationTurnLimit = 190.0f * kDeg;  // rad/s: spin, tumble
float turn_limit(const std::string& name) {
  return name == "spin" || name == "tumble" || name == "procedural" ? kFastRotationTurnLimit : kHandTurnLimit;
}
const std::vector<std::string> kRotationScenarios{"spin", "tumble", "slide", "cross"};

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
  ASSERT_EQ(names.size(), 11u);
  for (const std::string& name : names) {
    const Simulator sim(options_for(name));
    EXPECT_GE(sim.num_frames(), name == "procedural" ? 90 : 300) << name;
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
  EXPECT_FALSE(
      other.poses(0)[0].pose.translation.isApprox(Simulator(options_for("random", 3)).poses(0)[0].pose.translation));
}

// Frame 0 of every scenario (the seeded scenes for several seeds): every object is visible, and
// objects (and hands) are pairwise separated by at least 2 cm in the measured point cloud.
TEST(Simulator, ObjectsSeparatedAndVisibleAtFrameZero) {
  std::vector<SimulatorOptions> cases;
  for (const std::string& name : scenario_names()) cases.push_back(options_for(name));
  for (const std::string& name : kRotationScenarios) {
    for (const std::uint64_t seed : {2u, 3u, 4u}) cases.push_back(options_for(name, seed));
  }
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

// Over whole scenarios: speeds within hand-manipulation limits (faster turns in spin and tumble),
// nothing below the table top, no two bodies interpenetrating, and a carried object keeps its pose
// relative to its hand. The rotation scenarios' scenes vary with the seed: several seeds each.
TEST(Simulator, MotionIsPhysicallyPlausible) {
  std::vector<SimulatorOptions> cases;
  for (const std::string& name : scenario_names()) cases.push_back(options_for(name, 2));
  for (const std::string& name : kRotationScenarios) {
    for (const std::uint64_t seed : {1u, 3u, 4u, 5u}) cases.push_back(options_for(name, seed));
  }
  for (SimulatorOptions o : cases) {
    const std::string& name = o.scenario.name;
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
          ASSERT_LE(speed, 0.3f) << name << " seed " << o.scenario.seed << " frame " << frame << " body "
                                 << bodies[b].id;
          ASSERT_LE(turn, turn_limit(name))
              << name << " seed " << o.scenario.seed << " frame " << frame << " body " << bodies[b].id;
          // An object that moves is carried by a hand rigidly (hands-free scenarios: moves by itself).
          const bool moved = !world[b].isApprox(prev[b], 1e-5f);
          if (moved && !bodies[b].is_hand && !hands_free(name)) {
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
            ASSERT_GT(s.z(), -0.001f) << name << " seed " << o.scenario.seed << " frame " << frame << " body "
                                      << bodies[a].id << " below the table";
          }
          for (std::size_t b = 0; b < bodies.size(); ++b) {
            if (b == a) continue;
            for (const Primitive& other : bodies[b].primitives) {
              for (const Eigen::Vector3f& s : samples) {
                ASSERT_FALSE(inside(other, world[b], s, 0.001f))
                    << name << " seed " << o.scenario.seed << " frame " << frame << ": body " << bodies[a].id
                    << " inside body " << bodies[b].id;
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

namespace mfot::sim {
namespace {

// Per-frame turn of body b (index into bodies()) over a whole scenario: entry i is the rotation
// from frame i to frame i + 1, world axes.
std::vector<Eigen::AngleAxisf> turns_of(const Simulator& sim, std::size_t b) {
  std::vector<Eigen::AngleAxisf> out;
  Eigen::Isometry3f prev = world_poses(sim, 0)[b];
  for (int frame = 1; frame < sim.num_frames(); ++frame) {
    const Eigen::Isometry3f cur = world_poses(sim, frame)[b];
    out.emplace_back(Eigen::Matrix3f(cur.rotation() * prev.rotation().transpose()));
    prev = cur;
  }
  return out;
}

// Distance from world point p to the box primitive prim posed by body_to_world (0 inside).
float distance_to_box(const Primitive& prim, const Eigen::Isometry3f& body_to_world, const Eigen::Vector3f& p) {
  const Eigen::Vector3f q = (body_to_world * prim.pose.isometry()).inverse() * p;
  return (q.cwiseAbs() - 0.5f * prim.size).cwiseMax(0.0f).norm();
}

// The spinning box turns about the vertical at a steady 170 deg/s or more for at least 1 s, and
// its rate changes smoothly: by at most 20 deg/s from one frame to the next.
TEST(Simulator, SpinTurnsSteadilyAtUpTo180DegreesPerSecondWithoutVelocitySteps) {
  for (const std::uint64_t seed : {1u, 2u, 3u}) {
    const Simulator sim(options_for("spin", seed));
    const auto turns = turns_of(sim, 0);
    int run = 0, longest = 0;
    float previous_rate = 0.0f, largest_step = 0.0f;
    for (const Eigen::AngleAxisf& turn : turns) {
      const float rate = turn.angle() * 30.0f / kDeg;
      if (rate > 1.0f) {
        EXPECT_GT(std::abs(turn.axis().z()), 0.999f) << "seed " << seed;
      }
      const bool steady_fast = rate >= 170.0f && std::abs(rate - previous_rate) < 0.5f;
      run = steady_fast ? run + 1 : 0;
      longest = std::max(longest, run);
      largest_step = std::max(largest_step, std::abs(rate - previous_rate));
      previous_rate = rate;
    }
    EXPECT_GE(longest, 30) << "seed " << seed;
    EXPECT_LE(largest_step, 20.0f) << "seed " << seed;
    EXPECT_LE(previous_rate, 1e-3f) << "seed " << seed << ": at rest at the end";
  }
}

// The tumbling box turns two full turns or more about horizontal axes, floats (its lowest corner
// 5 cm or more above the table for a while) and never dips below the table.
TEST(Simulator, TumbleTurnsTwiceAboutHorizontalAxesAboveTheTable) {
  for (const std::uint64_t seed : {1u, 2u, 3u}) {
    const Simulator sim(options_for("tumble", seed));
    float horizontal = 0.0f;
    for (const Eigen::AngleAxisf& turn : turns_of(sim, 0)) horizontal += turn.angle() * turn.axis().head<2>().norm();
    EXPECT_GE(horizontal, 4.0f * kPi) << "seed " << seed;

    const Primitive& box = sim.bodies()[0].primitives[0];
    float highest_lowest = 0.0f;
    for (int frame = 0; frame < sim.num_frames(); ++frame) {
      const Eigen::Isometry3f pose = world_poses(sim, frame)[0];
      float lowest = 1e9f;
      for (int corner = 0; corner < 8; ++corner) {
        const Eigen::Vector3f f(corner & 1 ? 0.5f : -0.5f, corner & 2 ? 0.5f : -0.5f, corner & 4 ? 0.5f : -0.5f);
        lowest = std::min(lowest, (pose * box.pose.isometry() * f.cwiseProduct(box.size)).z());
      }
      ASSERT_GE(lowest, -1e-4f) << "seed " << seed << " frame " << frame;
      highest_lowest = std::max(highest_lowest, lowest);
    }
    EXPECT_GE(highest_lowest, 0.05f) << "seed " << seed;
  }
}

// The sliding box turns 0.6 rad or more and rests with a face against the other box's (within
// 1 mm) for at least 1 s.
TEST(Simulator, SlideTurnsAndTouchesTheOtherBox) {
  for (const std::uint64_t seed : {1u, 2u, 3u}) {
    const Simulator sim(options_for("slide", seed));
    const Primitive& mover = sim.bodies()[0].primitives[0];
    const Primitive& anchor = sim.bodies()[1].primitives[0];
    const Eigen::Matrix3f start = world_poses(sim, 0)[0].rotation();
    float largest_turn = 0.0f;
    int run = 0, longest = 0;
    for (int frame = 0; frame < sim.num_frames(); ++frame) {
      const auto world = world_poses(sim, frame);
      largest_turn =
          std::max(largest_turn, Eigen::AngleAxisf(Eigen::Matrix3f(world[0].rotation() * start.transpose())).angle());
      float closest = 1e9f;
      for (const Eigen::Vector3f& p : volume_samples(mover, world[0]))
        closest = std::min(closest, distance_to_box(anchor, world[1], p));
      run = closest <= 0.001f ? run + 1 : 0;
      longest = std::max(longest, run);
    }
    EXPECT_GE(largest_turn, 0.6f) << "seed " << seed;
    EXPECT_GE(longest, 30) << "seed " << seed;
  }
}

// The crossing box passes in front of the other one: for some frames it hides 30 % or more of the
// other box's pixels visible when it is out of the way.
TEST(Simulator, CrossHidesMuchOfTheOtherBoxOnItsWay) {
  for (const std::uint64_t seed : {1u, 2u}) {
    SimulatorOptions o = options_for("cross", seed);
    o.sensor.noise = false;
    const Simulator sim(o);
    int most = 0, fewest = 1 << 30;
    for (int frame = 0; frame < sim.num_frames(); frame += 3) {
      const RenderedFrame f = sim.render(frame);
      const auto visible = static_cast<int>(std::count(f.labels.begin(), f.labels.end(), std::uint16_t{2}));
      most = std::max(most, visible);
      fewest = std::min(fewest, visible);
    }
    EXPECT_GT(most, 1000) << "seed " << seed;
    EXPECT_LE(fewest, 0.7 * most) << "seed " << seed;
  }
}

// The seed varies the rotation scenarios' scenes: the moving box is elsewhere (or turned
// otherwise) half way through.
TEST(Simulator, RotationScenariosVaryWithTheSeed) {
  for (const std::string& name : kRotationScenarios) {
    const Simulator a(options_for(name, 1)), b(options_for(name, 2)), c(options_for(name, 3));
    const int middle = std::min({a.num_frames(), b.num_frames(), c.num_frames()}) / 2;
    const Eigen::Isometry3f pa = world_poses(a, middle)[0], pb = world_poses(b, middle)[0],
                            pc = world_poses(c, middle)[0];
    EXPECT_FALSE(pa.isApprox(pb, 1e-3f)) << name;
    EXPECT_FALSE(pb.isApprox(pc, 1e-3f)) << name;
    EXPECT_FALSE(pa.isApprox(pc, 1e-3f)) << name;
  }
}

}  // namespace
}  // namespace mfot::sim
