#pragma once
// Low-level ray caster of the simulator: renders one registered RGB-D frame of a scene given as
// analytic primitives (boxes, cylinders, planes) already posed in the camera frame. Simulator
// (simulator.hpp) builds such a scene from a scripted scenario for every frame; tests and tools
// may build their own scenes and call render_scene directly.
//
// Camera convention: pinhole, x right, y down, z forward (optical axis); pixel (u, v) centre
// looks along ((u - cx) / fx, (v - cy) / fy, 1). Depth is the z coordinate (not the ray length).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <vector>

#include "mfot/preprocessing.hpp"
#include "mfot/types.hpp"

namespace mfot::sim {

struct CameraIntrinsics {
  int width = 640, height = 480;
  float fx = 570.3f, fy = 570.3f, cx = 319.5f, cy = 239.5f;

  // Throws std::invalid_argument naming the field (width, height in [1, 8192]; fx, fy > 0).
  void validate() const;
};

// One ground-truth pose: object (or hand) frame -> camera frame.
struct GroundTruthPose {
  int id = 0;  // label value of the body in RenderedFrame::labels
  bool is_hand = false;
  Pose pose;
  Eigen::Vector3f symmetry_axis = Eigen::Vector3f::Zero();  // body frame, unit; zero = none (BodyInfo)
};

struct RenderedFrame {
  std::int64_t index = 0;
  double time_s = 0.0;
  CameraIntrinsics intrinsics;
  std::vector<std::uint16_t> depth_mm;  // row-major width x height, 0 = no measurement
  std::vector<Rgb8> color;              // row-major, registered to depth (same pixel grid)
  // Row-major: label of the surface the pixel's ray hits, also where its depth is missing (mask
  // with depth_mm > 0 for the measured points): 0 = table / background, k = object k (1..),
  // 101, 102 = hands (with forearm).
  std::vector<std::uint16_t> labels;
  std::vector<GroundTruthPose> poses;
};

// The frame as the Preprocessor takes it (a view: valid while frame lives).
RgbdImageView image_view(const RenderedFrame& frame);

// Kinect-like sensor model. With noise = false every random and quantising effect below is off
// (exact geometry, depth only rounded to the nearest millimetre by the uint16 format); the range
// limits always apply.
struct SensorOptions {
  bool noise = true;
  // Axial depth noise, Gaussian-like with sigma(z) = base + quadratic * (z - reference)^2
  // (Nguyen, Izadi, Lovell 2012, Kinect v1: 1.2 mm + 1.9 mm/m^2 * (z - 0.4 m)^2).
  float axial_sigma_base_m = 0.0012f;     // >= 0
  float axial_sigma_quadratic = 0.0019f;  // metres per m^2, >= 0
  float axial_sigma_reference_m = 0.4f;   // >= 0
  // Lateral noise: each pixel's ray is jittered in the image plane with this standard deviation
  // (pixels, per axis), so edges fray like a structured-light sensor's.
  float lateral_jitter_px = 0.25f;  // [0, 2]
  // Depth quantisation step after the noise (metres; 0 = none besides the uint16 millimetre).
  float depth_quantum_m = 0.001f;  // [0, 0.05]
  // Optional Kinect v1 disparity quantisation: depth is snapped to the depth of the nearest
  // disparity step of disparity_step_px at baseline_m, so steps grow with z^2 (about 2.9 mm at
  // 1 m for the defaults). Off by default: the axial noise model above was measured on real
  // sensor output and already contains the quantisation's spread.
  bool disparity_quantisation = false;
  float baseline_m = 0.075f;         // (0, 1]
  float disparity_step_px = 0.125f;  // (0, 1]
  // Missing depth where the angle between the ray and the surface normal exceeds this (degrees).
  float max_incidence_deg = 80.0f;  // (0, 90]
  // Missing depth at depth discontinuities: a pixel loses its depth when a pixel within
  // edge_band_px (Chebyshev distance) is nearer by more than discontinuity_m + discontinuity_rel * z
  // (the far side of an edge, like the structured-light shadow band).
  float discontinuity_m = 0.02f;    // > 0
  float discontinuity_rel = 0.02f;  // >= 0
  int edge_band_px = 1;             // [0, 4]; 0 disables
  float min_range_m = 0.4f;         // measurable depth range (z), 0 <= min < max
  float max_range_m = 4.0f;
  // Colour noise: per-channel, Gaussian-like, standard deviation in 8-bit levels.
  float color_sigma = 2.5f;  // [0, 64]

  // Throws std::invalid_argument naming the field and its allowed range.
  void validate() const;
};

// Surface pattern of a primitive. Texture coordinates are the local surface coordinates in metres.
enum class Pattern : std::uint8_t {
  solid,    // face colours only
  stripes,  // face colour alternating with pattern_color, stripes of pattern_period_m / 2
  checker,  // checkerboard of face colour and pattern_color, cells of pattern_period_m / 2
  // A printed label on the side surfaces (cylinder side; box faces +-x, +-y): over the middle 60 %
  // of the height and the first 65 % of the cylinder's circumference (the middle 80 % of a box
  // face's width), pattern_color printed with blocks of print_color in cells of pattern_period_m / 2
  // (a fixed hash of the cell picks them); face colour elsewhere. Turns about a cylinder's axis show.
  label,
};

enum class PrimitiveKind : std::uint8_t { box, cylinder };

struct Primitive {
  PrimitiveKind kind = PrimitiveKind::box;
  // box: full edge lengths along local x, y, z; cylinder: (diameter, diameter, height), axis
  // along local z, centred at the origin.
  Eigen::Vector3f size = Eigen::Vector3f::Constant(0.1f);
  Pose pose;  // primitive frame -> camera frame
  // box: faces +x, -x, +y, -y, +z, -z; cylinder: [0] side, [4] top (+z) cap, [5] bottom cap.
  std::array<Rgb8, 6> face_colors{};
  Pattern pattern = Pattern::solid;
  Rgb8 pattern_color{};
  Rgb8 print_color{};  // Pattern::label's print
  float pattern_period_m = 0.04f;
  std::uint16_t label = 1;
};

// An infinite or rectangular plane: the plane z = 0 of its frame, visible from the +z side only
// (its normal). half_extent_x / half_extent_y bound it in its frame (<= 0 = unbounded). Coloured
// with a checkerboard of color_a / color_b, cells tile_m wide (tile_m <= 0 = plain color_a).
struct Plane {
  Pose pose;  // plane frame -> camera frame
  float half_extent_x = 0.0f, half_extent_y = 0.0f;
  Rgb8 color_a{200, 200, 200}, color_b{200, 200, 200};
  float tile_m = 0.0f;
  std::uint16_t label = 0;
};

struct Scene {
  std::vector<Plane> planes;
  std::vector<Primitive> primitives;
  // Direction towards the light in the camera frame (normalised on use). Shading is Lambertian:
  // albedo * (ambient + (1 - ambient) * max(0, n . l)).
  Eigen::Vector3f light_direction = Eigen::Vector3f(0.0f, -1.0f, -0.5f);
  float ambient = 0.45f;
};

// Renders scene as one frame. The random draws of the sensor model are a pure function of
// (noise_seed, pixel), so the same inputs always give the same frame. The returned frame has
// index 0, time 0 and no poses; the caller fills those in.
RenderedFrame render_scene(const Scene& scene, const CameraIntrinsics& camera, const SensorOptions& sensor,
                           std::uint64_t noise_seed);

// Axial noise standard deviation of the model at depth z (metres).
float axial_sigma(const SensorOptions& sensor, float z_m);

}  // namespace mfot::sim
