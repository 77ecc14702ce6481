// Ray caster and Kinect-like sensor model of the simulator (scene.hpp).
//
// Steps of render_scene:
//  1. One ray per pixel through the pixel centre, jittered laterally when noise is on; rays are
//     kept as (x, y, 1) so the ray parameter of a hit is its depth z.
//  2. Planes: analytic ray-plane intersection for every pixel (a few flops each).
//  3. Primitives: the screen rectangle of each primitive's projected bounding box bounds its
//     pixels; inside it an analytic ray-box (slab) or ray-cylinder test in the primitive frame
//     keeps the nearest hit per pixel (a z-buffer of hit index, face and depth).
//  4. Shading: albedo from face colour and pattern, Lambertian light, colour noise.
//  5. Depth: grazing-angle dropout, axial noise sigma(z) (Nguyen, Izadi, Lovell 2012),
//     quantisation, range limits, then dropout on the far side of depth discontinuities.
// Random draws are a counter-based hash of (seed, pixel, stream), which keeps a frame a pure
// function of its inputs regardless of render order and costs a few cycles per draw.

#include "mfot/sim/scene.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace mfot::sim {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

void require(bool ok, const char* field, const char* range) {
  if (!ok) throw std::invalid_argument(std::string(field) + " must be " + range);
}

// SplitMix64 finaliser: a bijective mixer whose outputs pass as independent uniform 64-bit words
// for consecutive inputs.
std::uint64_t mix64(std::uint64_t z) {
  z += 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

// Unit-variance, zero-mean, Gaussian-like draw: sum of four 16-bit uniforms (Irwin-Hall, n = 4).
float gauss4(std::uint64_t h) {
  const auto sum = static_cast<float>((h & 0xffffU) + ((h >> 16) & 0xffffU) + ((h >> 32) & 0xffffU) + (h >> 48));
  constexpr float kMean = 2.0f * 65535.0f;
  constexpr float kInvStd = 1.7320508f / 65536.0f;  // std of the sum = sqrt(4 * 65536^2 / 12)
  return (sum - kMean) * kInvStd;
}

// Unit-variance, zero-mean triangular draw from two 16-bit uniforms in the low 32 bits of h.
float triangular(std::uint64_t h) {
  const auto sum = static_cast<float>((h & 0xffffU) + ((h >> 16) & 0xffffU));
  constexpr float kInvStd = 2.4494897f / 65536.0f;  // std of the sum = sqrt(2 * 65536^2 / 12)
  return (sum - 65535.0f) * kInvStd;
}

// Hit of the nearest surface along one pixel's ray. index < 0: nothing; [0, planes): a plane;
// [planes, planes + primitives): a primitive. face: box face 0..5 (+x, -x, +y, -y, +z, -z) or
// cylinder part (0 side, 4 top, 5 bottom).
struct Hit {
  float z = kInf;
  std::int16_t index = -1;
  std::uint8_t face = 0;
};

struct Frame3 {  // rotation columns and translation of a pose, as plain floats
  Eigen::Matrix3f r;
  Eigen::Vector3f t;
};

Frame3 frame_of(const Pose& p) { return {p.rotation.normalized().toRotationMatrix(), p.translation}; }

// Conservative pixel rectangle of a local axis-aligned box [-h, h] posed by f; false if wholly
// behind the camera. Corners behind the near plane make the rectangle the whole image.
bool screen_rect(const Frame3& f, const Eigen::Vector3f& half, const CameraIntrinsics& cam, float margin_px,
                 int& u0, int& v0, int& u1, int& v1) {
  float umin = kInf, vmin = kInf, umax = -kInf, vmax = -kInf;
  int behind = 0;
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3f local((c & 1) ? half.x() : -half.x(), (c & 2) ? half.y() : -half.y(),
                                (c & 4) ? half.z() : -half.z());
    const Eigen::Vector3f p = f.r * local + f.t;
    if (p.z() < 1e-3f) {
      ++behind;
      continue;
    }
    const float u = cam.fx * p.x() / p.z() + cam.cx, v = cam.fy * p.y() / p.z() + cam.cy;
    umin = std::min(umin, u);
    umax = std::max(umax, u);
    vmin = std::min(vmin, v);
    vmax = std::max(vmax, v);
  }
  if (behind == 8) return false;
  if (behind > 0) {
    u0 = 0, v0 = 0, u1 = cam.width - 1, v1 = cam.height - 1;
    return true;
  }
  u0 = std::max(0, static_cast<int>(std::floor(umin - margin_px)));
  v0 = std::max(0, static_cast<int>(std::floor(vmin - margin_px)));
  u1 = std::min(cam.width - 1, static_cast<int>(std::ceil(umax + margin_px)));
  v1 = std::min(cam.height - 1, static_cast<int>(std::ceil(vmax + margin_px)));
  return u0 <= u1 && v0 <= v1;
}

// Ray o + t d (primitive frame) against the box [-h, h]; nearest entry t > 0 and its face.
bool intersect_box(const float o[3], const float d[3], const float h[3], float& t_hit, std::uint8_t& face) {
  float t_near = -kInf, t_far = kInf;
  int axis = 0;
  for (int i = 0; i < 3; ++i) {
    if (d[i] == 0.0f) {
      if (o[i] < -h[i] || o[i] > h[i]) return false;
      continue;
    }
    const float inv = 1.0f / d[i];
    float ta = (-h[i] - o[i]) * inv, tb = (h[i] - o[i]) * inv;
    if (ta > tb) std::swap(ta, tb);
    if (ta > t_near) {
      t_near = ta;
      axis = i;
    }
    t_far = std::min(t_far, tb);
  }
  if (t_near > t_far || t_near <= 0.0f) return false;
  t_hit = t_near;
  face = static_cast<std::uint8_t>(2 * axis + (d[axis] > 0.0f ? 1 : 0));  // entering the -side when d > 0
  return true;
}

// Ray against the cylinder of radius r, half height hz along local z.
bool intersect_cylinder(const float o[3], const float d[3], float r, float hz, float& t_hit, std::uint8_t& face) {
  float best = kInf;
  std::uint8_t best_face = 0;
  const float a = d[0] * d[0] + d[1] * d[1];
  if (a > 0.0f) {
    const float b = o[0] * d[0] + o[1] * d[1];
    const float c = o[0] * o[0] + o[1] * o[1] - r * r;
    const float disc = b * b - a * c;
    if (disc < 0.0f) return false;  // the infinite cylinder is missed, so are its caps
    const float t = (-b - std::sqrt(disc)) / a;
    const float z = o[2] + t * d[2];
    if (t > 0.0f && z >= -hz && z <= hz) {
      best = t;
      best_face = 0;
    }
  }
  if (d[2] != 0.0f) {
    const float cap_z = o[2] > 0.0f ? hz : -hz;  // only the cap facing the ray origin can be entered
    const float t = (cap_z - o[2]) / d[2];
    if (t > 0.0f && t < best) {
      const float x = o[0] + t * d[0], y = o[1] + t * d[1];
      if (x * x + y * y <= r * r) {
        best = t;
        best_face = cap_z > 0.0f ? 4 : 5;
      }
    }
  }
  if (best == kInf) return false;
  t_hit = best;
  face = best_face;
  return true;
}

Rgb8 scale_color(Rgb8 c, float s) {
  auto ch = [s](std::uint8_t v) { return std::min(255.0f, static_cast<float>(v) * s); };
  return {static_cast<std::uint8_t>(ch(c.r) + 0.5f), static_cast<std::uint8_t>(ch(c.g) + 0.5f),
          static_cast<std::uint8_t>(ch(c.b) + 0.5f)};
}

bool pattern_odd(Pattern pattern, float u, float v, float half_period) {
  const auto cu = static_cast<long>(std::floor(u / half_period));
  switch (pattern) {
    case Pattern::solid:
      return false;
    case Pattern::stripes:
      return (cu & 1) != 0;
    case Pattern::checker:
      return ((cu + static_cast<long>(std::floor(v / half_period))) & 1) != 0;
  }
  return false;
}

// Albedo and local normal of a primitive at local point p on face.
Rgb8 primitive_albedo(const Primitive& prim, const Eigen::Vector3f& p, std::uint8_t face, Eigen::Vector3f& normal) {
  const Eigen::Vector3f half = prim.size * 0.5f;
  float u = 0.0f, v = 0.0f;
  if (prim.kind == PrimitiveKind::box) {
    const int axis = face / 2;
    normal = Eigen::Vector3f::Zero();
    normal[axis] = (face & 1) ? -1.0f : 1.0f;
    const int ua = axis == 0 ? 1 : 0, va = axis == 2 ? 1 : 2;
    u = p[ua] + half[ua];
    v = p[va] + half[va];
  } else if (face == 0) {
    normal = Eigen::Vector3f(p.x(), p.y(), 0.0f).normalized();
    u = (std::atan2(p.y(), p.x()) + 3.14159265f) * half.x();  // arc length around the axis
    v = p.z() + half.z();
  } else {
    normal = Eigen::Vector3f(0.0f, 0.0f, face == 4 ? 1.0f : -1.0f);
    u = p.x() + half.x();
    v = p.y() + half.y();
  }
  const bool odd = prim.pattern_period_m > 0.0f && pattern_odd(prim.pattern, u, v, 0.5f * prim.pattern_period_m);
  return odd ? prim.pattern_color : prim.face_colors[face];
}

}  // namespace

void CameraIntrinsics::validate() const {
  require(width >= 1 && width <= 8192, "CameraIntrinsics.width", "in [1, 8192]");
  require(height >= 1 && height <= 8192, "CameraIntrinsics.height", "in [1, 8192]");
  require(std::isfinite(fx) && fx > 0.0f, "CameraIntrinsics.fx", "finite and > 0");
  require(std::isfinite(fy) && fy > 0.0f, "CameraIntrinsics.fy", "finite and > 0");
  require(std::isfinite(cx), "CameraIntrinsics.cx", "finite");
  require(std::isfinite(cy), "CameraIntrinsics.cy", "finite");
}

void SensorOptions::validate() const {
  require(axial_sigma_base_m >= 0.0f && axial_sigma_base_m <= 0.1f, "SensorOptions.axial_sigma_base_m", "in [0, 0.1]");
  require(axial_sigma_quadratic >= 0.0f && axial_sigma_quadratic <= 0.1f, "SensorOptions.axial_sigma_quadratic",
          "in [0, 0.1]");
  require(axial_sigma_reference_m >= 0.0f && axial_sigma_reference_m <= 10.0f,
          "SensorOptions.axial_sigma_reference_m", "in [0, 10]");
  require(lateral_jitter_px >= 0.0f && lateral_jitter_px <= 2.0f, "SensorOptions.lateral_jitter_px", "in [0, 2]");
  require(depth_quantum_m >= 0.0f && depth_quantum_m <= 0.05f, "SensorOptions.depth_quantum_m", "in [0, 0.05]");
  require(baseline_m > 0.0f && baseline_m <= 1.0f, "SensorOptions.baseline_m", "in (0, 1]");
  require(disparity_step_px > 0.0f && disparity_step_px <= 1.0f, "SensorOptions.disparity_step_px", "in (0, 1]");
  require(max_incidence_deg > 0.0f && max_incidence_deg <= 90.0f, "SensorOptions.max_incidence_deg", "in (0, 90]");
  require(discontinuity_m > 0.0f && discontinuity_m <= 1.0f, "SensorOptions.discontinuity_m", "in (0, 1]");
  require(discontinuity_rel >= 0.0f && discontinuity_rel <= 1.0f, "SensorOptions.discontinuity_rel", "in [0, 1]");
  require(edge_band_px >= 0 && edge_band_px <= 4, "SensorOptions.edge_band_px", "in [0, 4]");
  require(min_range_m >= 0.0f && min_range_m < max_range_m, "SensorOptions.min_range_m", "in [0, max_range_m)");
  require(max_range_m <= 65.0f, "SensorOptions.max_range_m", "in (min_range_m, 65]");
  require(color_sigma >= 0.0f && color_sigma <= 64.0f, "SensorOptions.color_sigma", "in [0, 64]");
}

float axial_sigma(const SensorOptions& sensor, float z_m) {
  const float dz = z_m - sensor.axial_sigma_reference_m;
  return sensor.axial_sigma_base_m + sensor.axial_sigma_quadratic * dz * dz;
}

RenderedFrame render_scene(const Scene& scene, const CameraIntrinsics& cam, const SensorOptions& sensor,
                           std::uint64_t noise_seed) {
  cam.validate();
  sensor.validate();
  if (scene.planes.size() + scene.primitives.size() > 32000) {
    throw std::invalid_argument("Scene: at most 32000 planes and primitives");
  }
  const int w = cam.width, h = cam.height;
  const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  const bool noise = sensor.noise;
  const std::uint64_t seed = mix64(noise_seed ^ 0x6a09e667f3bcc909ULL);
  // Stream s of pixel i: mix64(seed + 4 i + s).
  auto draw = [seed](std::size_t i, std::uint64_t stream) { return mix64(seed + 4 * static_cast<std::uint64_t>(i) + stream); };

  // 1. Rays.
  std::vector<float> ray_x(n), ray_y(n);
  const float jitter = noise ? sensor.lateral_jitter_px : 0.0f;
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * w + u;
      float du = 0.0f, dv = 0.0f;
      if (jitter > 0.0f) {
        const std::uint64_t r = draw(i, 0);
        du = jitter * triangular(r);
        dv = jitter * triangular(r >> 32);
      }
      ray_x[i] = (static_cast<float>(u) + du - cam.cx) / cam.fx;
      ray_y[i] = (static_cast<float>(v) + dv - cam.cy) / cam.fy;
    }
  }

  std::vector<Hit> hits(n);
  const int num_planes = static_cast<int>(scene.planes.size());

  // 2. Planes.
  std::vector<Frame3> plane_frames;
  for (int k = 0; k < num_planes; ++k) {
    const Plane& plane = scene.planes[k];
    const Frame3 f = frame_of(plane.pose);
    plane_frames.push_back(f);
    const Eigen::Vector3f nrm = f.r.col(2), ex = f.r.col(0), ey = f.r.col(1);
    const float n_dot_p0 = nrm.dot(f.t);
    if (n_dot_p0 >= 0.0f) continue;  // camera behind the plane: its front side is invisible
    const bool bounded_x = plane.half_extent_x > 0.0f, bounded_y = plane.half_extent_y > 0.0f;
    const float ex_p0 = ex.dot(f.t), ey_p0 = ey.dot(f.t);
    for (std::size_t i = 0; i < n; ++i) {
      const float denom = nrm.x() * ray_x[i] + nrm.y() * ray_y[i] + nrm.z();
      if (denom >= 0.0f) continue;
      const float t = n_dot_p0 / denom;
      if (t >= hits[i].z) continue;
      if (bounded_x && std::abs(t * (ex.x() * ray_x[i] + ex.y() * ray_y[i] + ex.z()) - ex_p0) > plane.half_extent_x) continue;
      if (bounded_y && std::abs(t * (ey.x() * ray_x[i] + ey.y() * ray_y[i] + ey.z()) - ey_p0) > plane.half_extent_y) continue;
      hits[i] = {t, static_cast<std::int16_t>(k), 0};
    }
  }

  // 3. Primitives.
  std::vector<Frame3> prim_frames;
  const float margin = 1.0f + 4.0f * jitter;
  for (std::size_t k = 0; k < scene.primitives.size(); ++k) {
    const Primitive& prim = scene.primitives[k];
    const Frame3 f = frame_of(prim.pose);
    prim_frames.push_back(f);
    const Eigen::Vector3f half = prim.size * 0.5f;
    int u0 = 0, v0 = 0, u1 = 0, v1 = 0;
    if (!screen_rect(f, half, cam, margin, u0, v0, u1, v1)) continue;
    // Camera origin and ray-direction basis in the primitive frame: d_local = rt * (x, y, 1).
    const Eigen::Matrix3f rt = f.r.transpose();
    const Eigen::Vector3f o = -(rt * f.t);
    const float org[3] = {o.x(), o.y(), o.z()};
    const float hh[3] = {half.x(), half.y(), half.z()};
    const auto index = static_cast<std::int16_t>(num_planes + static_cast<int>(k));
    const bool is_box = prim.kind == PrimitiveKind::box;
    for (int v = v0; v <= v1; ++v) {
      for (int u = u0; u <= u1; ++u) {
        const std::size_t i = static_cast<std::size_t>(v) * w + u;
        const float x = ray_x[i], y = ray_y[i];
        const float d[3] = {rt(0, 0) * x + rt(0, 1) * y + rt(0, 2), rt(1, 0) * x + rt(1, 1) * y + rt(1, 2),
                            rt(2, 0) * x + rt(2, 1) * y + rt(2, 2)};
        float t = 0.0f;
        std::uint8_t face = 0;
        const bool hit = is_box ? intersect_box(org, d, hh, t, face) : intersect_cylinder(org, d, hh[0], hh[2], t, face);
        if (hit && t < hits[i].z) hits[i] = {t, index, face};
      }
    }
  }

  // 4. and 5. Shading and depth per pixel.
  RenderedFrame frame;
  frame.intrinsics = cam;
  frame.depth_mm.assign(n, 0);
  frame.color.assign(n, Rgb8{});
  frame.labels.assign(n, 0);
  const Eigen::Vector3f light = scene.light_direction.normalized();
  const float cos_max_incidence = std::cos(sensor.max_incidence_deg * 3.14159265f / 180.0f);
  const float fb = cam.fx * sensor.baseline_m;  // disparity (pixels) * depth (m)
  const float color_sigma = noise ? sensor.color_sigma : 0.0f;
  for (std::size_t i = 0; i < n; ++i) {
    const Hit& hit = hits[i];
    if (hit.index < 0) continue;
    const Eigen::Vector3f dir(ray_x[i], ray_y[i], 1.0f);
    const Eigen::Vector3f p = hit.z * dir;
    Eigen::Vector3f normal;
    Rgb8 albedo;
    if (hit.index < num_planes) {
      const Plane& plane = scene.planes[hit.index];
      const Frame3& f = plane_frames[hit.index];
      normal = f.r.col(2);
      albedo = plane.color_a;
      if (plane.tile_m > 0.0f) {
        const Eigen::Vector3f q = p - f.t;
        const auto cu = static_cast<long>(std::floor(f.r.col(0).dot(q) / plane.tile_m));
        const auto cv = static_cast<long>(std::floor(f.r.col(1).dot(q) / plane.tile_m));
        if ((cu + cv) & 1) albedo = plane.color_b;
      }
      frame.labels[i] = plane.label;
    } else {
      const int k = hit.index - num_planes;
      const Primitive& prim = scene.primitives[k];
      const Frame3& f = prim_frames[k];
      Eigen::Vector3f local_normal;
      albedo = primitive_albedo(prim, f.r.transpose() * (p - f.t), hit.face, local_normal);
      normal = f.r * local_normal;
      frame.labels[i] = prim.label;
    }
    const float shade = scene.ambient + (1.0f - scene.ambient) * std::max(0.0f, normal.dot(light));
    Rgb8 c = scale_color(albedo, shade);
    if (color_sigma > 0.0f) {
      const std::uint64_t r = draw(i, 2);
      auto noisy = [color_sigma](std::uint8_t ch, std::uint64_t bits) {
        // Triangular draw from two 10-bit uniforms (unit variance).
        const auto s = static_cast<float>((bits & 0x3ffU) + ((bits >> 10) & 0x3ffU));
        const float g = (s - 1023.0f) * (2.4494897f / 1024.0f);
        return static_cast<std::uint8_t>(std::clamp(static_cast<float>(ch) + color_sigma * g + 0.5f, 0.0f, 255.0f));
      };
      c = {noisy(c.r, r), noisy(c.g, r >> 20), noisy(c.b, r >> 40)};
    }
    frame.color[i] = c;

    float z = hit.z;
    if (noise) {
      const float cos_incidence = std::abs(normal.dot(dir)) / dir.norm();
      if (cos_incidence < cos_max_incidence) continue;
      z += axial_sigma(sensor, z) * gauss4(draw(i, 1));
      if (sensor.disparity_quantisation && z > 0.0f) {
        const float disparity = std::round(fb / z / sensor.disparity_step_px) * sensor.disparity_step_px;
        z = disparity > 0.0f ? fb / disparity : kInf;
      }
      if (sensor.depth_quantum_m > 0.0f) z = std::round(z / sensor.depth_quantum_m) * sensor.depth_quantum_m;
    }
    if (!(z >= sensor.min_range_m && z <= sensor.max_range_m)) continue;
    frame.depth_mm[i] = static_cast<std::uint16_t>(std::lround(z * 1000.0f));
  }

  // 5b. Far side of depth discontinuities: min filter of the true depth over the band (separable).
  if (noise && sensor.edge_band_px > 0) {
    const int band = sensor.edge_band_px;
    std::vector<float> row_min(n), near(n);
    for (int v = 0; v < h; ++v) {
      const std::size_t row = static_cast<std::size_t>(v) * w;
      for (int u = 0; u < w; ++u) {
        float m = kInf;
        for (int du = std::max(0, u - band); du <= std::min(w - 1, u + band); ++du) m = std::min(m, hits[row + du].z);
        row_min[row + u] = m;
      }
    }
    for (int v = 0; v < h; ++v) {
      for (int u = 0; u < w; ++u) {
        float m = kInf;
        for (int dv = std::max(0, v - band); dv <= std::min(h - 1, v + band); ++dv) {
          m = std::min(m, row_min[static_cast<std::size_t>(dv) * w + u]);
        }
        near[static_cast<std::size_t>(v) * w + u] = m;
      }
    }
    for (std::size_t i = 0; i < n; ++i) {
      const float z = hits[i].z;
      if (z != kInf && near[i] < z - (sensor.discontinuity_m + sensor.discontinuity_rel * z)) frame.depth_mm[i] = 0;
    }
  }
  return frame;
}

}  // namespace mfot::sim
