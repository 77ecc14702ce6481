#include "mfot/sim/simulator.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include "mfot/splitmix.hpp"
#include "script.hpp"

namespace mfot::sim {

namespace {

void require(bool ok, const char* field, const char* range) {
  if (!ok) throw std::invalid_argument(std::string(field) + " must be " + range);
}

// Minimum visible pixels of every object at frame 0 for a random layout to be kept.
constexpr int kMinVisiblePixels = 200;
constexpr int kLayoutAttempts = 32;

}  // namespace

std::vector<std::string> procedural_motion_names() { return {"slide", "push", "spin", "tilt", "stack", "tumble"}; }

std::string SceneSummary::source_name() const {
  if (motion.empty()) return "sim:" + scenario;
  std::string moved;
  for (const Object& o : objects) {
    if (o.moved) moved += (moved.empty() ? "" : "+") + o.shape;
  }
  return "sim:" + scenario + ":" + std::to_string(seed) + ":" + motion + ":" + moved;
}

std::string SceneSummary::yaml() const {
  std::ostringstream out;
  out << "scenario: " << scenario << "\nseed: " << seed << "\n";
  if (motion.empty()) return out.str();
  out << "motion: " << motion << "\nmover: " << mover << "\n";
  out << "camera_height_m: " << camera_height_m << "\ncamera_pitch_deg: " << camera_pitch_rad * 180.0f / 3.14159265f
      << "\n";
  if (motion == "spin" || motion == "tumble") {
    out << "spin_axis: [" << spin_axis.x() << ", " << spin_axis.y() << ", " << spin_axis.z() << "]\n";
    out << "spin_angle_rad: " << spin_angle_rad << "\n";
    if (motion == "spin") out << "spin_on_table: " << (spin_on_table ? "true" : "false") << "\n";
  }
  if (stack_base_id > 0) out << "stack_base_id: " << stack_base_id << "\n";
  out << "objects:\n";
  for (const Object& o : objects) {
    out << "  - {id: " << o.id << ", shape: " << o.shape << ", texture: " << o.texture
        << ", moved: " << (o.moved ? "true" : "false") << "}\n";
  }
  return out.str();
}

std::vector<std::string> scenario_names() {
  return {"stack", "contact", "rotate", "apart", "static", "random", "spin", "tumble", "slide", "cross", "procedural"};
}

void ScenarioOptions::validate() const {
  const auto names = scenario_names();
  require(std::find(names.begin(), names.end(), name) != names.end(), "ScenarioOptions.name",
          "one of stack, contact, rotate, apart, static, random, spin, tumble, slide, cross, procedural");
  require(num_frames >= 0 && num_frames <= 1000000, "ScenarioOptions.num_frames", "in [0, 1000000]");
  require(num_objects >= 1 && num_objects <= 16, "ScenarioOptions.num_objects", "in [1, 16]");
  require(speed > 0.0f && speed <= 0.2f, "ScenarioOptions.speed", "in (0, 0.2] m/s");
  require(occlusion >= 0.0f && occlusion <= 1.0f, "ScenarioOptions.occlusion", "in [0, 1]");
}

void SimulatorOptions::validate() const {
  scenario.validate();
  sensor.validate();
  camera.validate();
}

struct Simulator::Impl {
  SimulatorOptions options;
  detail::World world;
  detail::Script script;
  std::vector<BodyInfo> bodies;
  int num_frames = 0;

  detail::Iso body_to_camera(int b, double t) const { return world.world_to_camera * detail::pose_at(script, b, t); }

  Scene scene(double t) const {
    Scene s;
    for (Plane plane : world.planes) {
      plane.pose = Pose::from_isometry(world.world_to_camera * plane.pose.isometry());
      s.planes.push_back(plane);
    }
    for (std::size_t b = 0; b < bodies.size(); ++b) {
      const detail::Iso to_camera = body_to_camera(static_cast<int>(b), t);
      for (Primitive prim : bodies[b].primitives) {
        prim.pose = Pose::from_isometry(to_camera * prim.pose.isometry());
        s.primitives.push_back(prim);
      }
    }
    s.light_direction = world.world_to_camera.linear() * world.light_direction;
    return s;
  }

  bool all_objects_visible() const {
    SensorOptions exact = options.sensor;
    exact.noise = false;
    const RenderedFrame frame = render_scene(scene(0.0), options.camera, exact, 0);
    std::vector<int> count(bodies.size() + 1, 0);
    for (std::size_t i = 0; i < frame.labels.size(); ++i) {
      const int label = frame.labels[i];
      if (frame.depth_mm[i] > 0 && label >= 1 && label <= static_cast<int>(bodies.size())) ++count[label];
    }
    for (const BodyInfo& body : bodies) {
      if (!body.is_hand && count[body.id] < kMinVisiblePixels) return false;
    }
    return true;
  }

  void load(int attempt) {
    script = detail::build_scenario(options.scenario, attempt);
    world = script.world ? *script.world : detail::make_world();
    script.summary.scenario = options.scenario.name;
    script.summary.seed = options.scenario.seed;
    bodies.clear();
    for (const detail::BodyScript& body : script.bodies) bodies.push_back(body.info);
  }
};

Simulator::Simulator(const SimulatorOptions& options) : impl_(std::make_unique<Impl>()) {
  options.validate();
  impl_->options = options;
  impl_->load(0);
  if (options.scenario.name == "random" || options.scenario.name == "procedural") {
    for (int attempt = 1; attempt < kLayoutAttempts && !impl_->all_objects_visible(); ++attempt) impl_->load(attempt);
  }
  impl_->num_frames = options.scenario.num_frames > 0
                          ? options.scenario.num_frames
                          : static_cast<int>(std::lround(impl_->script.duration_s * detail::kFps));
}

Simulator::~Simulator() = default;
Simulator::Simulator(Simulator&&) noexcept = default;
Simulator& Simulator::operator=(Simulator&&) noexcept = default;

int Simulator::num_frames() const { return impl_->num_frames; }

double Simulator::fps() const { return detail::kFps; }

std::vector<GroundTruthPose> Simulator::poses(int index) const {
  if (index < 0 || index >= impl_->num_frames) throw std::out_of_range("Simulator: frame index out of range");
  const double t = index / detail::kFps;
  std::vector<GroundTruthPose> out;
  for (std::size_t b = 0; b < impl_->bodies.size(); ++b) {
    out.push_back({impl_->bodies[b].id, impl_->bodies[b].is_hand,
                   Pose::from_isometry(impl_->body_to_camera(static_cast<int>(b), t)), impl_->bodies[b].symmetry_axis});
  }
  return out;
}

Scene Simulator::scene(int index) const {
  if (index < 0 || index >= impl_->num_frames) throw std::out_of_range("Simulator: frame index out of range");
  return impl_->scene(index / detail::kFps);
}

RenderedFrame Simulator::render(int index) const {
  const Scene s = scene(index);
  const std::uint64_t noise_seed = mix64(impl_->options.scenario.seed ^ mix64(static_cast<std::uint64_t>(index)));
  RenderedFrame frame = render_scene(s, impl_->options.camera, impl_->options.sensor, noise_seed);
  frame.index = index;
  frame.time_s = index / detail::kFps;
  frame.poses = poses(index);
  return frame;
}

const SimulatorOptions& Simulator::options() const { return impl_->options; }

const std::vector<BodyInfo>& Simulator::bodies() const { return impl_->bodies; }

const SceneSummary& Simulator::summary() const { return impl_->script.summary; }

Pose Simulator::world_to_camera() const { return Pose::from_isometry(impl_->world.world_to_camera); }

}  // namespace mfot::sim
