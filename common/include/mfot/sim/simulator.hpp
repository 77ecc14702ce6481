#pragma once
// Table-top RGB-D scene simulator with ground truth: the built-in input of mfot that lets the
// tracker run, be tested and be measured without a camera (thesis chapter 4's experiments:
// stacking, contact, rotation, static scene, plus a seeded random scene, plus hands-free scenes of
// rotating, tumbling and crossing objects: spin, tumble, slide, cross; plus `procedural`, a seeded
// generator of whole scenes: shapes, textures, motion programme, mover, object count and camera).
//
// World frame: table top is z = 0, x to the right, y away from the camera, z up. The camera looks
// down at the table centre from 1 m away at 45 degrees (like a robot head). Boxes (faces of
// distinct colours, some striped or checkered) and cylinders (cans) rest on the table or on each
// other; rigid skin-coloured hands (palm + fingers box, one cylinder for forearm and upper arm)
// reach in from the image sides, grasp objects (grasped objects move rigidly with the hand) and
// leave again. In random, spin, tumble, slide and cross objects move by themselves, sliding on the
// table or (tumble) floating above it as on an invisible holder; random's hands only pass over
// them. Motion is piecewise and smooth (ease-in/ease-out; spin and tumble also turn at constant
// velocity between ramps, without velocity steps) with peak speeds of at most 0.3 m/s and 90 deg/s,
// except spin's and tumble's turns: up to 180 deg/s. Every frame is rendered by analytic ray
// casting with a Kinect-like sensor model (scene.hpp) and comes with every body's pose and a label
// image.
//
// Body frames: an object's origin is its geometric centre (box / cylinder centre), axes along its
// edges / cylinder axis; a hand's origin is its palm centre, x along the fingers, z out of the
// back of the hand.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "mfot/sim/scene.hpp"

namespace mfot::sim {

struct ScenarioOptions {
  // One of scenario_names(): "stack", "contact", "rotate", "apart", "static", "random", "spin",
  // "tumble", "slide", "cross", "procedural".
  std::string name = "stack";
  // Sensor noise (all scenarios), the random scenario's layout, spin's, tumble's, slide's and
  // cross's scene (turn directions, amounts and rates, start yaws, paths), and the whole procedural
  // scene. Procedural seeds 1-999 are for development, 1000 and up for acceptance only.
  std::uint64_t seed = 1;
  int num_frames = 0;  // 0: the scenario's own length; longer holds the last pose; [0, 1000000]
  // The random scenario only (procedural draws its own):
  int num_objects = 3;     // [1, 16]
  float speed = 0.1f;      // mean sliding speed of objects, m/s, (0, 0.2] (peak is 1.5x)
  float occlusion = 0.3f;  // [0, 1]: share of the time hands pass over the objects (0 = no hands)

  void validate() const;
};

struct SimulatorOptions {
  ScenarioOptions scenario;
  SensorOptions sensor;
  CameraIntrinsics camera;

  // Throws std::invalid_argument naming the offending field and its allowed range.
  void validate() const;
};

// Static description of one body of a scenario (for consumers that want the geometry).
struct BodyInfo {
  int id = 0;  // label value: objects 1.., hands 101, 102
  bool is_hand = false;
  std::vector<Primitive> primitives;  // poses relative to the body frame, labels = id
  // A body that looks the same turned about this body-frame axis (a plain can's: shape and texture
  // symmetric): rotation about it does not show, so the evaluator reports the error of the observable
  // rotation beside the full one. Zero: no symmetry axis (a can whose texture varies around it has none).
  Eigen::Vector3f symmetry_axis = Eigen::Vector3f::Zero();
};

// What a scene is made of, so reports can group runs by it. The scripted scenarios fill in the
// scenario and seed only; a procedural scene also its motion class, mover, objects and camera.
struct SceneSummary {
  struct Object {
    int id = 0;           // label value
    std::string shape;    // box | can | bottle | mug
    std::string texture;  // plain | stripes | label | checker
    bool moved = false;   // moved by the motion programme
  };
  std::string scenario;
  std::uint64_t seed = 0;
  std::string motion;  // one of procedural_motion_names(); empty for the scripted scenarios
  std::string mover;   // hand | gripper | none: what visibly moves the object
  std::vector<Object> objects;
  // spin: the turn axis in the moved object's body frame (unit), the whole turn (radians, signed),
  // and whether it turns standing on the table (about its vertical axis) or lifted.
  Eigen::Vector3f spin_axis = Eigen::Vector3f::Zero();
  float spin_angle_rad = 0.0f;
  bool spin_on_table = false;
  int stack_base_id = 0;          // stack: the object the moved one ends on
  float camera_height_m = 0.0f;   // above the table top
  float camera_pitch_rad = 0.0f;  // below the horizontal

  // "sim:<scenario>", or for a procedural scene "sim:procedural:<seed>:<motion>:<moved shapes>".
  std::string source_name() const;
  // A small YAML document of the fields above (ground-truth folders' scene.yaml).
  std::string yaml() const;
};

// The procedural scenes' motion classes: slide, push, spin, tilt, stack, tumble.
std::vector<std::string> procedural_motion_names();

class Simulator {
 public:
  explicit Simulator(const SimulatorOptions& options);
  ~Simulator();
  Simulator(Simulator&&) noexcept;
  Simulator& operator=(Simulator&&) noexcept;
  Simulator(const Simulator&) = delete;
  Simulator& operator=(const Simulator&) = delete;

  int num_frames() const;
  double fps() const;  // 30

  // Frame index in [0, num_frames()). Deterministic: the same options and index always give an
  // identical frame, independent of which frames were rendered before. Thread-safe (const).
  RenderedFrame render(int index) const;

  // Ground-truth poses (body -> camera) at frame index, without rendering.
  std::vector<GroundTruthPose> poses(int index) const;
  // The scene of frame index in the camera frame (what render() ray casts).
  Scene scene(int index) const;

  const SimulatorOptions& options() const;
  const std::vector<BodyInfo>& bodies() const;
  const SceneSummary& summary() const;
  Pose world_to_camera() const;  // maps world (table) coordinates to camera coordinates

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

std::vector<std::string> scenario_names();

}  // namespace mfot::sim
