// Ray caster and sensor model: exact geometry against hand-computed intersections, label image
// against geometry, noise statistics against the model.

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "mfot/sim/scene.hpp"

namespace mfot::sim {
namespace {

constexpr float kPi = 3.14159265f;

// Intrinsics whose pixel (320, 240) looks straight down the optical axis.
CameraIntrinsics centred_camera() {
  CameraIntrinsics cam;
  cam.cx = 320.0f;
  cam.cy = 240.0f;
  return cam;
}

SensorOptions exact_sensor() {
  SensorOptions s;
  s.noise = false;
  return s;
}

std::size_t at(const CameraIntrinsics& cam, int u, int v) { return static_cast<std::size_t>(v) * cam.width + u; }

Eigen::Vector3f ray(const CameraIntrinsics& cam, int u, int v) {
  return {(static_cast<float>(u) - cam.cx) / cam.fx, (static_cast<float>(v) - cam.cy) / cam.fy, 1.0f};
}

Primitive box(const Eigen::Vector3f& size, const Eigen::Vector3f& centre, const Eigen::Quaternionf& rotation,
              std::uint16_t label) {
  Primitive p;
  p.kind = PrimitiveKind::box;
  p.size = size;
  p.pose.translation = centre;
  p.pose.rotation = rotation;
  for (auto& c : p.face_colors) c = {200, 50, 50};
  p.label = label;
  return p;
}

// A plane facing the camera (normal -z) at depth z.
Plane facing_plane(float z) {
  Plane plane;
  plane.pose.translation = Eigen::Vector3f(0.0f, 0.0f, z);
  plane.pose.rotation = Eigen::Quaternionf(Eigen::AngleAxisf(kPi, Eigen::Vector3f::UnitX()));
  plane.color_a = plane.color_b = {120, 130, 140};
  return plane;
}

TEST(RenderScene, AxisAlignedBoxFrontFaceDepth) {
  const CameraIntrinsics cam = centred_camera();
  Scene scene;
  scene.primitives.push_back(box({0.2f, 0.1f, 0.1f}, {0.05f, -0.02f, 1.0f}, Eigen::Quaternionf::Identity(), 7));
  const RenderedFrame f = render_scene(scene, cam, exact_sensor(), 1);
  // The front face is the plane z = 1.0 - 0.05; x in [-0.05, 0.15], y in [-0.07, 0.03] there.
  for (const auto& [u, v] : {std::pair{320, 240}, std::pair{400, 250}, std::pair{300, 200}}) {
    EXPECT_EQ(f.depth_mm[at(cam, u, v)], 950) << u << "," << v;
    EXPECT_EQ(f.labels[at(cam, u, v)], 7);
  }
  // x = 0.95 * (500 - 320) / 570.3 = 0.30 is beyond the box: nothing there.
  EXPECT_EQ(f.depth_mm[at(cam, 500, 240)], 0);
  EXPECT_EQ(f.labels[at(cam, 500, 240)], 0);
}

TEST(RenderScene, RotatedBoxDepthMatchesRayPlaneIntersection) {
  const CameraIntrinsics cam = centred_camera();
  const Eigen::Quaternionf rotation(Eigen::AngleAxisf(0.5f, Eigen::Vector3f::UnitY()));
  const Eigen::Vector3f centre(0.0f, 0.0f, 0.9f), size(0.3f, 0.2f, 0.1f);
  Scene scene;
  scene.primitives.push_back(box(size, centre, rotation, 3));
  const RenderedFrame f = render_scene(scene, cam, exact_sensor(), 1);
  // The face facing the camera is local -z: outward normal n = R (0, 0, -1), plane n . p = n . c + 0.05.
  const Eigen::Vector3f n = rotation * Eigen::Vector3f(0.0f, 0.0f, -1.0f);
  for (const auto& [u, v] : {std::pair{320, 240}, std::pair{350, 230}, std::pair{290, 260}, std::pair{330, 215}}) {
    const Eigen::Vector3f d = ray(cam, u, v);
    const float t = (n.dot(centre) + 0.5f * size.z()) / n.dot(d);
    const Eigen::Vector3f local = rotation.inverse() * (t * d - centre);
    ASSERT_LT(std::abs(local.x()), 0.5f * size.x());  // the chosen pixels do see that face
    ASSERT_LT(std::abs(local.y()), 0.5f * size.y());
    EXPECT_NEAR(f.depth_mm[at(cam, u, v)], 1000.0f * t, 0.51f) << u << "," << v;
    EXPECT_EQ(f.labels[at(cam, u, v)], 3);
  }
}

TEST(RenderScene, CylinderSideDepth) {
  const CameraIntrinsics cam = centred_camera();
  Primitive can;
  can.kind = PrimitiveKind::cylinder;
  can.size = Eigen::Vector3f(0.1f, 0.1f, 0.3f);  // radius 0.05, axis along camera y after the rotation
  can.pose.translation = Eigen::Vector3f(0.0f, 0.0f, 1.0f);
  can.pose.rotation = Eigen::Quaternionf(Eigen::AngleAxisf(kPi / 2.0f, Eigen::Vector3f::UnitX()));
  can.label = 2;
  Scene scene;
  scene.primitives.push_back(can);
  const RenderedFrame f = render_scene(scene, cam, exact_sensor(), 1);
  const float r = 0.05f;
  for (int u : {320, 330, 345, 300}) {
    // Ray (x, y, 1) t meets x^2 + (z - 1)^2 = r^2: t^2 (1 + x^2) - 2 t + 1 - r^2 = 0, nearer root.
    const float x = (static_cast<float>(u) - cam.cx) / cam.fx;
    const float a = 1.0f + x * x;
    const float t = (1.0f - std::sqrt(1.0f - a * (1.0f - r * r))) / a;
    EXPECT_NEAR(f.depth_mm[at(cam, u, 250)], 1000.0f * t, 0.51f) << u;
    EXPECT_EQ(f.labels[at(cam, u, 250)], 2);
  }
  // x * 0.95 = 0.05 at u = 350: beyond it the ray misses.
  EXPECT_EQ(f.labels[at(cam, 360, 250)], 0);
}

TEST(RenderScene, LabelImageMatchesGeometry) {
  const CameraIntrinsics cam;
  const Eigen::Quaternionf rotation(Eigen::AngleAxisf(0.7f, Eigen::Vector3f(1.0f, 2.0f, 0.5f).normalized()));
  const Eigen::Vector3f centre(-0.05f, 0.03f, 0.8f), size(0.15f, 0.1f, 0.12f);
  Scene scene;
  scene.planes.push_back(facing_plane(1.2f));
  scene.primitives.push_back(box(size, centre, rotation, 5));
  const RenderedFrame f = render_scene(scene, cam, exact_sensor(), 1);
  int box_pixels = 0;
  const Eigen::Matrix3f to_local = rotation.inverse().toRotationMatrix();
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      const std::size_t i = at(cam, u, v);
      ASSERT_GT(f.depth_mm[i], 0);
      const Eigen::Vector3f p = 0.001f * f.depth_mm[i] * ray(cam, u, v);
      const Eigen::Vector3f local = rotation.inverse() * (p - centre);
      // Distance of p outside the box (0 inside): on the box surface within the millimetre rounding.
      const float outside = (local.cwiseAbs() - 0.5f * size).cwiseMax(0.0f).norm();
      if (f.labels[i] == 5) {
        ++box_pixels;
        ASSERT_LT(outside, 0.002f) << u << "," << v;
        ASSERT_LT(f.depth_mm[i], 1200);
      } else {
        ASSERT_EQ(f.labels[i], 0);
        ASSERT_EQ(f.depth_mm[i], 1200);
        // The ray to the plane misses the box: no point of it (2 mm steps over the box's depth range)
        // lies inside the box shrunk by 1 mm. (Pixels far from the box's image are skipped.)
        if (std::abs(u - 284) > 150 || std::abs(v - 261) > 150) continue;
        for (float z = 0.6f; z < 1.0f; z += 0.002f) {
          const Eigen::Vector3f q = to_local * (z * ray(cam, u, v) - centre);
          ASSERT_FALSE(((q.cwiseAbs() - 0.5f * size).array() < -0.001f).all()) << u << "," << v;
        }
      }
    }
  }
  EXPECT_GT(box_pixels, 2000);
}

TEST(RenderScene, AxialNoiseMatchesModel) {
  const CameraIntrinsics cam;
  for (const float z : {0.8f, 1.5f, 2.5f}) {
    Scene scene;
    scene.planes.push_back(facing_plane(z));
    const SensorOptions sensor;  // defaults: noise on, 1 mm quantisation
    const RenderedFrame f = render_scene(scene, cam, sensor, 42);
    double sum = 0.0, sum2 = 0.0;
    int count = 0;
    for (std::uint16_t d : f.depth_mm) {
      ASSERT_GT(d, 0);
      const double e = d * 0.001 - z;
      sum += e;
      sum2 += e * e;
      ++count;
    }
    const double mean = sum / count, std = std::sqrt(sum2 / count - mean * mean);
    const double sigma = axial_sigma(sensor, z);
    // Rounding to 1 mm adds a uniform error of variance q^2 / 12.
    const double expected = std::sqrt(sigma * sigma + 1e-6 / 12.0);
    EXPECT_NEAR(std, expected, 0.03 * expected) << "z = " << z;
    EXPECT_NEAR(mean, 0.0, 0.0002) << "z = " << z;
  }
  EXPECT_NEAR(axial_sigma(SensorOptions{}, 1.4f), 0.0012f + 0.0019f, 1e-7f);
}

TEST(RenderScene, ColourNoiseMatchesSigma) {
  const CameraIntrinsics cam;
  Scene scene;
  scene.planes.push_back(facing_plane(1.0f));
  SensorOptions sensor;
  sensor.color_sigma = 4.0f;
  const RenderedFrame noisy = render_scene(scene, cam, sensor, 3);
  sensor.noise = false;
  const RenderedFrame exact = render_scene(scene, cam, sensor, 3);
  double sum2 = 0.0;
  for (std::size_t i = 0; i < noisy.color.size(); ++i) {
    ASSERT_EQ(exact.color[i], exact.color[0]);
    const double e = static_cast<double>(noisy.color[i].g) - exact.color[i].g;
    sum2 += e * e;
  }
  const double std = std::sqrt(sum2 / static_cast<double>(noisy.color.size()));
  const double expected = std::sqrt(16.0 + 1.0 / 12.0);
  EXPECT_NEAR(std, expected, 0.05 * expected);
}

TEST(RenderScene, GrazingSurfacesLoseDepth) {
  const CameraIntrinsics cam = centred_camera();
  for (const float tilt_deg : {70.0f, 85.0f}) {
    // Plane through (0, 0, 1) whose normal makes tilt_deg with the central ray, facing the camera.
    Plane plane = facing_plane(1.0f);
    plane.pose.rotation =
        Eigen::Quaternionf(Eigen::AngleAxisf(tilt_deg * kPi / 180.0f, Eigen::Vector3f::UnitY())) * plane.pose.rotation;
    Scene scene;
    scene.planes.push_back(plane);
    const RenderedFrame noisy = render_scene(scene, cam, SensorOptions{}, 9);
    const RenderedFrame exact = render_scene(scene, cam, exact_sensor(), 9);
    EXPECT_GT(exact.depth_mm[at(cam, 320, 240)], 0);
    EXPECT_EQ(noisy.labels[at(cam, 320, 240)], 0);
    if (tilt_deg > 80.0f) {
      EXPECT_EQ(noisy.depth_mm[at(cam, 320, 240)], 0);
    } else {
      EXPECT_NEAR(noisy.depth_mm[at(cam, 320, 240)], 1000, 20);
    }
  }
}

TEST(RenderScene, FarSideOfDepthEdgesLosesDepth) {
  const CameraIntrinsics cam;
  Scene scene;
  scene.planes.push_back(facing_plane(1.2f));
  scene.primitives.push_back(box({0.2f, 0.2f, 0.1f}, {0.0f, 0.0f, 0.8f}, Eigen::Quaternionf::Identity(), 1));
  const RenderedFrame exact = render_scene(scene, cam, exact_sensor(), 4);
  const RenderedFrame noisy = render_scene(scene, cam, SensorOptions{}, 4);
  // Plane pixels next to the box (Chebyshev distance 1) vs plane pixels 4+ pixels away.
  int near_total = 0, near_missing = 0, far_total = 0, far_missing = 0;
  for (int v = 5; v < cam.height - 5; ++v) {
    for (int u = 5; u < cam.width - 5; ++u) {
      if (exact.labels[at(cam, u, v)] != 0) continue;
      int distance = 99;
      for (int dv = -4; dv <= 4; ++dv) {
        for (int du = -4; du <= 4; ++du) {
          if (exact.labels[at(cam, u + du, v + dv)] == 1)
            distance = std::min(distance, std::max(std::abs(du), std::abs(dv)));
        }
      }
      const bool missing = noisy.depth_mm[at(cam, u, v)] == 0;
      if (distance == 1) near_total += 1, near_missing += missing;
      if (distance == 99) far_total += 1, far_missing += missing;
    }
  }
  ASSERT_GT(near_total, 400);
  EXPECT_GT(near_missing, 0.8 * near_total);
  EXPECT_EQ(far_missing, 0);
  // The box's own pixels (the near side) keep their depth away from its silhouette.
  EXPECT_GT(noisy.depth_mm[at(cam, 319, 239)], 0);
}

TEST(RenderScene, NoiseIsAPureFunctionOfTheSeed) {
  const CameraIntrinsics cam;
  Scene scene;
  scene.planes.push_back(facing_plane(1.0f));
  scene.primitives.push_back(box({0.2f, 0.2f, 0.1f}, {0.0f, 0.0f, 0.8f}, Eigen::Quaternionf::Identity(), 1));
  const RenderedFrame a = render_scene(scene, cam, SensorOptions{}, 11);
  const RenderedFrame b = render_scene(scene, cam, SensorOptions{}, 11);
  const RenderedFrame c = render_scene(scene, cam, SensorOptions{}, 12);
  EXPECT_EQ(a.depth_mm, b.depth_mm);
  EXPECT_EQ(a.color, b.color);
  EXPECT_EQ(a.labels, b.labels);
  int differing = 0;
  for (std::size_t i = 0; i < a.depth_mm.size(); ++i) differing += a.depth_mm[i] != c.depth_mm[i];
  EXPECT_GT(differing, static_cast<int>(a.depth_mm.size() / 4));
}

TEST(RenderScene, InvalidOptionsThrow) {
  SensorOptions s;
  s.max_incidence_deg = 95.0f;
  EXPECT_THROW(s.validate(), std::invalid_argument);
  s = SensorOptions{};
  s.min_range_m = 5.0f;
  EXPECT_THROW(s.validate(), std::invalid_argument);
  CameraIntrinsics cam;
  cam.fx = 0.0f;
  EXPECT_THROW(render_scene(Scene{}, cam, SensorOptions{}, 0), std::invalid_argument);
}

}  // namespace
}  // namespace mfot::sim
