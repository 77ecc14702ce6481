#pragma once
// A ray-cast table-top RGB-D frame for the preprocessing tests and benchmark: a finite table
// (world plane z = 0) with axis-aligned boxes on it, seen by a pinhole camera looking at a target.

#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "mfot/preprocessing.hpp"

namespace mfot::test_scene {

struct Box {
  Eigen::Vector3f min;
  Eigen::Vector3f max;
  Rgb8 color;
};

struct Scene {
  float table_half_extent = 0.6f;  // table covers |x|, |y| <= this, metres
  Rgb8 table_color{120, 120, 120};
  std::vector<Box> boxes;
};

struct Camera {
  int width = 640;
  int height = 480;
  CameraIntrinsics intrinsics{};
  Eigen::Vector3f eye{0.f, -0.7f, 0.75f};
  Eigen::Vector3f target{0.f, 0.f, 0.f};
  float depth_noise_mm = 0.f;  // uniform +- this, from a fixed seed
  std::uint64_t noise_seed = 1;

  // Camera-to-world rotation: camera x right, y down, z forward.
  Eigen::Matrix3f rotation() const {
    const Eigen::Vector3f forward = (target - eye).normalized();
    const Eigen::Vector3f right = forward.cross(Eigen::Vector3f::UnitZ()).normalized();
    const Eigen::Vector3f down = forward.cross(right);
    Eigen::Matrix3f r;
    r.col(0) = right;
    r.col(1) = down;
    r.col(2) = forward;
    return r;
  }
  Eigen::Vector3f world_to_camera(const Eigen::Vector3f& w) const { return rotation().transpose() * (w - eye); }
  Eigen::Vector3f camera_to_world(const Eigen::Vector3f& c) const { return rotation() * c + eye; }
  // The table plane in the camera frame, normal towards the camera (the Preprocessor convention).
  Eigen::Vector4f table_plane() const {
    Eigen::Vector4f plane;
    plane << rotation().transpose() * Eigen::Vector3f::UnitZ(), eye.z();
    return plane;
  }
};

struct Frame {
  int width = 0;
  int height = 0;
  CameraIntrinsics intrinsics;
  std::vector<std::uint16_t> depth_mm;
  std::vector<Rgb8> color;

  RgbdImageView view() const { return RgbdImageView{width, height, intrinsics, depth_mm, color}; }
};

// Ray parameter of the entry into an axis-aligned box, or +inf.
inline float ray_box(const Eigen::Vector3f& o, const Eigen::Vector3f& d, const Box& box) {
  float t_near = 0.f;
  float t_far = std::numeric_limits<float>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-12f) {
      if (o[a] < box.min[a] || o[a] > box.max[a]) return std::numeric_limits<float>::infinity();
      continue;
    }
    float t0 = (box.min[a] - o[a]) / d[a];
    float t1 = (box.max[a] - o[a]) / d[a];
    if (t0 > t1) std::swap(t0, t1);
    t_near = std::max(t_near, t0);
    t_far = std::min(t_far, t1);
    if (t_near > t_far) return std::numeric_limits<float>::infinity();
  }
  return t_near > 0.f ? t_near : std::numeric_limits<float>::infinity();
}

inline Frame render(const Scene& scene, const Camera& camera) {
  Frame frame;
  frame.width = camera.width;
  frame.height = camera.height;
  frame.intrinsics = camera.intrinsics;
  frame.depth_mm.assign(static_cast<std::size_t>(camera.width * camera.height), 0);
  frame.color.assign(frame.depth_mm.size(), Rgb8{});
  const Eigen::Matrix3f r = camera.rotation();
  std::mt19937_64 noise(camera.noise_seed);
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      // Camera ray with unit z, so the hit parameter is the camera-frame depth.
      const Eigen::Vector3f ray_c((static_cast<float>(u) - camera.intrinsics.cx) / camera.intrinsics.fx,
                                  (static_cast<float>(v) - camera.intrinsics.cy) / camera.intrinsics.fy, 1.f);
      const Eigen::Vector3f d = r * ray_c;
      float best = std::numeric_limits<float>::infinity();
      Rgb8 color{};
      if (d.z() < 0.f) {
        const float t = -camera.eye.z() / d.z();
        const Eigen::Vector3f hit = camera.eye + t * d;
        if (std::abs(hit.x()) <= scene.table_half_extent && std::abs(hit.y()) <= scene.table_half_extent) {
          best = t;
          color = scene.table_color;
        }
      }
      for (const Box& box : scene.boxes) {
        const float t = ray_box(camera.eye, d, box);
        if (t < best) {
          best = t;
          color = box.color;
        }
      }
      if (!std::isfinite(best)) continue;
      float mm = best * 1000.f;
      if (camera.depth_noise_mm > 0.f) {
        const float unit = static_cast<float>(noise() >> 40) / static_cast<float>(1u << 24);  // [0, 1)
        mm += (2.f * unit - 1.f) * camera.depth_noise_mm;
      }
      const std::size_t index = static_cast<std::size_t>(v * camera.width + u);
      frame.depth_mm[index] = static_cast<std::uint16_t>(std::lround(mm));
      frame.color[index] = color;
    }
  }
  return frame;
}

// Two boxes 25 cm apart on the table.
inline Scene two_boxes() {
  Scene scene;
  scene.boxes.push_back(Box{{-0.25f, -0.05f, 0.f}, {-0.15f, 0.05f, 0.10f}, Rgb8{200, 30, 30}});
  scene.boxes.push_back(Box{{0.10f, 0.00f, 0.f}, {0.20f, 0.10f, 0.08f}, Rgb8{30, 180, 40}});
  return scene;
}

}  // namespace mfot::test_scene
