#pragma once
// Scripted motion of the simulator's bodies (private to mfot_sim).
//
// A body's world pose over time is either keyframe interpolation or, while it is carried, the
// carrying hand's pose times a fixed offset (so carried objects move rigidly with the hand).
// Between keyframes the pose follows the profile s(tau) of the segment's end key, by default
// ease-in/ease-out s = 3 tau^2 - 2 tau^3 (zero velocity at every keyframe): the rotation is slerped
// with s and a pivot point of the body moves on a straight line with s (the pivot is the carried
// object's centre for a carrying hand, so an object turned in the hand rotates about its own
// centre; the body origin otherwise). Slerp takes the shorter way: keys of one turn must be less
// than 180 degrees apart.

#include <Eigen/Geometry>
#include <array>
#include <limits>
#include <optional>
#include <random>
#include <vector>

#include "mfot/sim/simulator.hpp"

namespace mfot::sim::detail {

using Iso = Eigen::Isometry3f;

// Progress s(tau) of a segment over its normalised time tau in [0, 1]. Chained so that the speeds
// meet (a segment of angle A over T ends ease_in at 2 A / T, runs linear at A / T, starts ease_out
// at 2 A / T), they turn at constant velocity between a start and an end at rest.
enum class Profile {
  eased,     // 3 tau^2 - 2 tau^3: at rest at both ends
  linear,    // tau: constant velocity
  ease_in,   // tau^2: starts at rest, ends at speed
  ease_out,  // 2 tau - tau^2: starts at speed, ends at rest
};

// s(tau) of profile.
double progress(Profile profile, double tau);

struct Keyframe {
  double t = 0.0;
  Iso pose = Iso::Identity();                       // body -> world
  Eigen::Vector3f pivot = Eigen::Vector3f::Zero();  // body frame; used by the segment ending here
  Profile profile = Profile::eased;                 // of the segment ending here
};

struct Attachment {
  int carrier = -1;  // body index of the hand
  double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
  Iso offset = Iso::Identity();  // carried body -> carrier body
};

struct BodyScript {
  BodyInfo info;
  std::vector<Keyframe> keys;           // sorted by t
  std::vector<Attachment> attachments;  // disjoint intervals
};

// The fixed surroundings: camera placement, table, floor and wall (plane poses: plane -> world).
struct World {
  Iso world_to_camera = Iso::Identity();
  std::vector<Plane> planes;
  Eigen::Vector3f light_direction = Eigen::Vector3f::UnitZ();  // towards the light, world frame
};

struct Script {
  std::vector<BodyScript> bodies;
  double duration_s = 0.0;
  std::optional<World> world;  // the scenario's own surroundings; none: make_world()'s
  SceneSummary summary;        // scenario and seed filled in by the Simulator
};

// Uniform draws by own transforms of the generator's bits (identical on every platform).
class Draw {
 public:
  explicit Draw(std::uint64_t seed) : gen_(seed) {}
  double operator()(double lo, double hi) { return lo + (hi - lo) * static_cast<double>(gen_() >> 11) * 0x1.0p-53; }
  float f(double lo, double hi) { return static_cast<float>((*this)(lo, hi)); }
  int index(int n) { return static_cast<int>(gen_() % static_cast<std::uint64_t>(n)); }

 private:
  std::mt19937_64 gen_;
};

// Distinct, saturated face colours (none close to the table's wood or to skin).
constexpr Rgb8 kRed{200, 30, 35}, kGreen{35, 160, 60}, kBlue{35, 70, 200}, kYellow{235, 205, 35},
    kMagenta{190, 40, 165}, kCyan{30, 175, 195}, kOrange{240, 115, 20}, kPurple{105, 50, 165}, kWhite{235, 235, 230},
    kBlack{35, 35, 40}, kLime{150, 215, 45}, kPink{240, 140, 180}, kGrey{140, 140, 150};
constexpr std::array<Rgb8, 13> kPalette{kRed,    kGreen, kBlue,  kYellow, kMagenta, kCyan, kOrange,
                                        kPurple, kWhite, kBlack, kLime,   kPink,    kGrey};

// World pose of body b at time t.
Iso pose_at(const Script& script, int b, double t);

// Peak speeds of the scripted motion (ease-in/ease-out peak is 1.5x the mean): the builder picks
// segment durations so that neither is exceeded by any moving body's origin. Keys added directly
// set their own pace (spin and tumble turn faster).
constexpr double kMaxLinearSpeed = 0.27;   // m/s
constexpr double kMaxAngularSpeed = 1.40;  // rad/s (80 deg/s)
constexpr double kFps = 30.0;

// Builds a Script as a sequence of phases on a common timeline. A phase moves some bodies to
// targets simultaneously; carried objects follow their hand.
class ScriptBuilder {
 public:
  int add_body(BodyInfo info, const Iso& world_pose);
  const Iso& pose(int body) const { return current_[body]; }
  const BodyInfo& info(int body) const { return script_.bodies[body].info; }
  double now() const { return now_; }

  // Moves each (body, target) of one phase; duration is at least min_duration_s and long enough
  // for the speed limits, rounded up to whole frames. Returns the duration.
  struct Target {
    int body;
    Iso pose;
  };
  double move(const std::vector<Target>& targets, double min_duration_s = 0.5);
  // The hand target that puts the object carried by hand at object_pose.
  Iso hand_target_for(int hand, const Iso& object_pose) const;
  void grasp(int hand, int object);
  void release(int hand);
  void wait(double seconds);
  // Adds a keyframe at time t without moving the timeline (independent per-body schedules);
  // profile shapes the segment that ends at it.
  void key(int body, double t, const Iso& pose, Profile profile = Profile::eased);
  // World pose of body at time t under the keyframes and grasps added so far.
  Iso scripted_pose(int body, double t) const { return pose_at(script_, body, t); }

  Script finish(double extra_wait_s);

 private:
  Script script_;
  std::vector<Iso> current_;
  std::vector<int> carried_by_;  // per body: carrying hand or -1
  std::vector<int> carrying_;    // per body (hands): carried object or -1
  double now_ = 0.0;
};

// Mean-speed-safe duration of the ease-in/ease-out move from a to b with the given pivot.
double min_move_duration(const Iso& a, const Iso& b, const Eigen::Vector3f& pivot);

// Interpolated pose between a and b at normalised time tau in [0, 1].
Iso interpolate(const Iso& a, const Iso& b, const Eigen::Vector3f& pivot, double tau, Profile profile = Profile::eased);

// ---- bodies ------------------------------------------------------------------------------
BodyInfo make_box(int id, const Eigen::Vector3f& size, const std::array<Rgb8, 6>& faces,
                  Pattern pattern = Pattern::solid, Rgb8 pattern_color = {}, float period_m = 0.04f);
BodyInfo make_can(int id, float diameter, float height, Rgb8 side, Rgb8 stripe, Rgb8 caps, float period_m = 0.03f);
// A rigid hand: palm box, bent fingers box, and one cylinder for forearm and upper arm rising
// 20 degrees from the wrist towards up_local (hand frame: x along the fingers, z out of the back of
// the hand; up_local is z for grasps from above, +-y for grasps from the side).
BodyInfo make_hand(int id, const Eigen::Vector3f& up_local = Eigen::Vector3f::UnitZ());
// Hand pose (world) grasping from above an object at object_pose with extent size (body info),
// fingers pointing along the object's local direction at yaw in its horizontal plane and hanging
// over the face there, palm resting on the top face.
Iso top_grasp(const BodyInfo& object, const Iso& object_pose, float yaw);

// Hand pose (world) grasping an upright object from the side: palm vertical against its -x face
// (side = -1) or +x face (side = +1), fingers pointing away from the camera (+y) and wrapping the
// far face's edge. Use with make_hand(id, {0, side, 0}) so the arm rises.
Iso side_grasp(const BodyInfo& object, const Iso& object_pose, float side);

// Half height of a body: the largest extent of its primitives along local z from the body origin
// (a single primitive centred at the origin: half its height).
float half_height(const BodyInfo& object);
// Radius of the body's footprint circle about its origin (table plane) when upright.
float footprint_radius(const BodyInfo& object);
// Half extents of the body-frame axis-aligned box around all its primitives, which must be
// centred on the origin (objects; their primitives are axis-aligned in the body frame).
Eigen::Vector3f half_extents(const BodyInfo& object);

// ---- scenarios ---------------------------------------------------------------------------
// The table, floor, wall and light, with the camera `distance` (metres) from the look-at point
// `target` on the table top and `pitch` (radians) below the horizontal, looking along +y. The
// defaults are the scripted scenarios' camera.
World make_world(float pitch = 3.14159265f / 4.0f, float distance = 1.0f,
                 const Eigen::Vector3f& target = Eigen::Vector3f(0.0f, 0.05f, 0.0f));

// The script of options.name. attempt varies the random scenario's layout (the simulator retries
// layouts whose objects are hidden at frame 0); the scripted scenarios ignore it.
Script build_scenario(const ScenarioOptions& options, int attempt);

// The seeded procedural scene (procedural.cpp); attempt varies it like random's.
Script procedural_scenario(const ScenarioOptions& options, int attempt);

}  // namespace mfot::sim::detail
