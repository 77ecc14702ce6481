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

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "mfot/sim/scene.hpp"
#include "mfot/splitmix.hpp"

namespace mfot::sim {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

void require(bool ok, const char* field, const char* range) {
  if (!ok) throw std::invalid_argument(std::string(field) + " must be " + range);
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
  float ray_x = 0.0f, ray_y = 0.0f;  // the pixel's ray direction (x, y, 1)
  float z = kInf;
  std::int16_t index = -1;
  std::uint8_t face = 0;
};

struct Frame3 {  // rotation columns and translation of a pose, as plain floats
  Eigen::Matrix3f r;
  Eigen::Vector3f t;
};

Frame3 frame_of(const Pose& p) { return {p.rotation.normalized().toRotationMatrix(), p.translation}; }

// Conservative pixel rectangle of a local axis-aligned box [-h, h] posed by f: the projection of
// the box clipped at the near plane z = kNear. False if the box lies wholly behind it or off-image.
bool screen_rect(const Frame3& f, const Eigen::Vector3f& half, const CameraIntrinsics& cam, float margin_px, int& u0,
                 int& v0, int& u1, int& v1) {
  constexpr float kNear = 0.01f;
  std::array<Eigen::Vector3f, 8> corners;
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3f local((c & 1) ? half.x() : -half.x(), (c & 2) ? half.y() : -half.y(),
                                (c & 4) ? half.z() : -half.z());
    corners[c] = f.r * local + f.t;
  }
  float umin = kInf, vmin = kInf, umax = -kInf, vmax = -kInf;
  auto add = [&](const Eigen::Vector3f& p) {
    const float u = cam.fx * p.x() / p.z() + cam.cx, v = cam.fy * p.y() / p.z() + cam.cy;
    umin = std::min(umin, u);
    umax = std::max(umax, u);
    vmin = std::min(vmin, v);
    vmax = std::max(vmax, v);
  };
  for (const Eigen::Vector3f& p : corners) {
    if (p.z() >= kNear) add(p);
  }
  // Edges (corner pairs differing in one bit) that cross the near plane add their crossing point.
  for (int a = 0; a < 8; ++a) {
    for (int bit = 1; bit < 8; bit <<= 1) {
      const int b = a | bit;
      if (b == a) continue;
      const Eigen::Vector3f& pa = corners[a];
      const Eigen::Vector3f& pb = corners[b];
      if ((pa.z() < kNear) == (pb.z() < kNear)) continue;
      add(pa + (pb - pa) * ((kNear - pa.z()) / (pb.z() - pa.z())));
    }
  }
  if (!(umin <= umax)) return false;
  u0 = static_cast<int>(std::max(0.0f, std::floor(umin - margin_px)));
  v0 = static_cast<int>(std::max(0.0f, std::floor(vmin - margin_px)));
  u1 = static_cast<int>(std::min(static_cast<float>(cam.width - 1), std::ceil(umax + margin_px)));
  v1 = static_cast<int>(std::min(static_cast<float>(cam.height - 1), std::ceil(vmax + margin_px)));
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
    case Pattern::label:
      return false;  // label_albedo
  }
  return false;
}

// Pattern::label's albedo at surface coordinates (u, v) of face (scene.hpp); half: the primitive's
// half size.
Rgb8 label_albedo(const Primitive& prim, std::uint8_t face, float u, float v, const Eigen::Vector3f& half) {
  const bool side = prim.kind == PrimitiveKind::box ? face < 4 : face == 0;
  if (!side || v < 0.4f * half.z() || v > 1.6f * half.z()) return prim.face_colors[face];
  if (prim.kind == PrimitiveKind::box) {
    const float width = 2.0f * (face < 2 ? half.y() : half.x());
    if (u < 0.1f * width || u > 0.9f * width) return prim.face_colors[face];
  } else if (u > 0.65f * 2.0f * 3.14159265f * half.x()) {
    return prim.face_colors[face];
  }
  if (!(prim.pattern_period_m > 0.0f)) return prim.pattern_color;
  const float cell = 0.5f * prim.pattern_period_m;
  const auto cu = static_cast<std::uint64_t>(static_cast<std::int64_t>(std::floor(u / cell)));
  const auto cv = static_cast<std::uint64_t>(static_cast<std::int64_t>(std::floor(v / cell)));
  const bool printed = (mix64(cu * 0x9e3779b97f4a7c15ULL ^ (cv + 0x632be59bd9b4e019ULL) ^ face) & 3U) == 0U;
  return printed ? prim.print_color : prim.pattern_color;
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
  if (prim.pattern == Pattern::label) return label_albedo(prim, face, u, v, half);
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
  require(axial_sigma_reference_m >= 0.0f && axial_sigma_reference_m <= 10.0f, "SensorOptions.axial_sigma_reference_m",
          "in [0, 10]");
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

RgbdImageView image_view(const RenderedFrame& frame) {
  const CameraIntrinsics& k = frame.intrinsics;
  return RgbdImageView{k.width, k.height, mfot::CameraIntrinsics{k.fx, k.fy, k.cx, k.cy}, frame.depth_mm, frame.color};
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
  auto draw = [seed](std::size_t i, std::uint64_t stream) {
    return mix64(seed + 4 * static_cast<std::uint64_t>(i) + stream);
  };

  // 1. Rays.
  std::vector<Hit> hits(n);
  const float jitter = noise ? sensor.lateral_jitter_px : 0.0f;
  const float inv_fx = 1.0f / cam.fx, inv_fy = 1.0f / cam.fy;
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * w + u;
      float du = 0.0f, dv = 0.0f;
      if (jitter > 0.0f) {
        const std::uint64_t r = draw(i, 0);
        du = jitter * triangular(r);
        dv = jitter * triangular(r >> 32);
      }
      hits[i].ray_x = (static_cast<float>(u) + du - cam.cx) * inv_fx;
      hits[i].ray_y = (static_cast<float>(v) + dv - cam.cy) * inv_fy;
    }
  }

  // 2. Planes, all in one pass over the pixels.
  const int num_planes = static_cast<int>(scene.planes.size());
  struct PlaneRay {  // plane terms of the ray test, camera frame
    Eigen::Vector3f normal, ex, ey;
    float n_dot_p0, ex_p0, ey_p0, half_x, half_y;
    std::int16_t index;
  };
  std::vector<Frame3> plane_frames;
  std::vector<PlaneRay> visible_planes;
  for (int k = 0; k < num_planes; ++k) {
    const Plane& plane = scene.planes[k];
    const Frame3 f = frame_of(plane.pose);
    plane_frames.push_back(f);
    const float n_dot_p0 = f.r.col(2).dot(f.t);
    if (n_dot_p0 >= 0.0f) continue;  // camera behind the plane: its front side is invisible
    visible_planes.push_back({f.r.col(2), f.r.col(0), f.r.col(1), n_dot_p0, f.r.col(0).dot(f.t), f.r.col(1).dot(f.t),
                              plane.half_extent_x > 0.0f ? plane.half_extent_x : kInf,
                              plane.half_extent_y > 0.0f ? plane.half_extent_y : kInf, static_cast<std::int16_t>(k)});
  }
  if (!visible_planes.empty()) {
    for (Hit& hit : hits) {
      const float x = hit.ray_x, y = hit.ray_y;
      for (const PlaneRay& pl : visible_planes) {
        const float denom = pl.normal.x() * x + pl.normal.y() * y + pl.normal.z();
        if (denom >= 0.0f) continue;
        const float t = pl.n_dot_p0 / denom;
        if (t >= hit.z) continue;
        if (std::abs(t * (pl.ex.x() * x + pl.ex.y() * y + pl.ex.z()) - pl.ex_p0) > pl.half_x) continue;
        if (std::abs(t * (pl.ey.x() * x + pl.ey.y() * y + pl.ey.z()) - pl.ey_p0) > pl.half_y) continue;
        hit.z = t;
        hit.index = pl.index;
      }
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
      Hit* row = hits.data() + static_cast<std::size_t>(v) * w;
      for (int u = u0; u <= u1; ++u) {
        Hit& px = row[u];
        const float x = px.ray_x, y = px.ray_y;
        const float d[3] = {rt(0, 0) * x + rt(0, 1) * y + rt(0, 2), rt(1, 0) * x + rt(1, 1) * y + rt(1, 2),
                            rt(2, 0) * x + rt(2, 1) * y + rt(2, 2)};
        float t = 0.0f;
        std::uint8_t face = 0;
        const bool hit =
            is_box ? intersect_box(org, d, hh, t, face) : intersect_cylinder(org, d, hh[0], hh[2], t, face);
        if (hit && t < px.z) {
          px.z = t;
          px.index = index;
          px.face = face;
        }
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
  auto shade_of = [&](const Eigen::Vector3f& normal) {
    return scene.ambient + (1.0f - scene.ambient) * std::max(0.0f, normal.dot(light));
  };
  struct PlaneShading {  // per plane: constant shade, checker coordinates u = a . p - b
    float shade;
    Eigen::Vector3f au, av;
    float bu, bv;
  };
  std::vector<PlaneShading> plane_shading;
  for (int k = 0; k < num_planes; ++k) {
    const Frame3& f = plane_frames[k];
    const float inv_tile = scene.planes[k].tile_m > 0.0f ? 1.0f / scene.planes[k].tile_m : 0.0f;
    plane_shading.push_back({shade_of(f.r.col(2)), f.r.col(0) * inv_tile, f.r.col(1) * inv_tile,
                             f.r.col(0).dot(f.t) * inv_tile, f.r.col(1).dot(f.t) * inv_tile});
  }
  const float cos_max_incidence = std::cos(sensor.max_incidence_deg * 3.14159265f / 180.0f);
  const float cos2_max_incidence = cos_max_incidence * cos_max_incidence;
  const float fb = cam.fx * sensor.baseline_m;  // disparity (pixels) * depth (m)
  const float color_sigma = noise ? sensor.color_sigma : 0.0f;
  const float inv_quantum = sensor.depth_quantum_m > 0.0f ? 1.0f / sensor.depth_quantum_m : 0.0f;
  for (std::size_t i = 0; i < n; ++i) {
    const Hit& hit = hits[i];
    if (hit.index < 0) continue;
    const Eigen::Vector3f dir(hit.ray_x, hit.ray_y, 1.0f);
    const Eigen::Vector3f p = hit.z * dir;
    Eigen::Vector3f normal;
    Rgb8 albedo;
    float shade = 0.0f;
    if (hit.index < num_planes) {
      const Plane& plane = scene.planes[hit.index];
      const PlaneShading& ps = plane_shading[hit.index];
      normal = plane_frames[hit.index].r.col(2);
      albedo = plane.color_a;
      if (plane.tile_m > 0.0f) {
        const auto cu = static_cast<long>(std::floor(ps.au.dot(p) - ps.bu));
        const auto cv = static_cast<long>(std::floor(ps.av.dot(p) - ps.bv));
        if ((cu + cv) & 1) albedo = plane.color_b;
      }
      shade = ps.shade;
      frame.labels[i] = plane.label;
    } else {
      const int k = hit.index - num_planes;
      const Primitive& prim = scene.primitives[k];
      const Frame3& f = prim_frames[k];
      Eigen::Vector3f local_normal;
      albedo = primitive_albedo(prim, f.r.transpose() * (p - f.t), hit.face, local_normal);
      normal = f.r * local_normal;
      shade = shade_of(normal);
      frame.labels[i] = prim.label;
    }
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
      const float n_dot_d = normal.dot(dir);
      if (n_dot_d * n_dot_d < cos2_max_incidence * dir.squaredNorm()) continue;
      z += axial_sigma(sensor, z) * gauss4(draw(i, 1));
      if (sensor.disparity_quantisation && z > 0.0f) {
        const float disparity = std::floor(fb / z / sensor.disparity_step_px + 0.5f) * sensor.disparity_step_px;
        z = disparity > 0.0f ? fb / disparity : kInf;
      }
      if (sensor.depth_quantum_m > 0.0f) z = std::floor(z * inv_quantum + 0.5f) * sensor.depth_quantum_m;
    }
    if (!(z >= sensor.min_range_m && z <= sensor.max_range_m)) continue;
    frame.depth_mm[i] = static_cast<std::uint16_t>(z * 1000.0f + 0.5f);
  }

  // 5b. Far side of depth discontinuities: min filter of the true depth over the band, separable
  // (contiguous rows so the loops vectorise).
  if (noise && sensor.edge_band_px > 0) {
    const int band = sensor.edge_band_px;
    std::vector<float> depth(n), row_min(n);
    for (std::size_t i = 0; i < n; ++i) depth[i] = hits[i].z;
    for (int v = 0; v < h; ++v) {
      const float* in = depth.data() + static_cast<std::size_t>(v) * w;
      float* out = row_min.data() + static_cast<std::size_t>(v) * w;
      std::copy(in, in + w, out);
      for (int d = 1; d <= band && d < w; ++d) {
        for (int u = d; u < w; ++u) out[u] = std::min(out[u], in[u - d]);
        for (int u = 0; u + d < w; ++u) out[u] = std::min(out[u], in[u + d]);
      }
    }
    // Column pass back into depth, which now holds the band minimum.
    for (int v = 0; v < h; ++v) {
      float* out = depth.data() + static_cast<std::size_t>(v) * w;
      std::copy(row_min.data() + static_cast<std::size_t>(v) * w, row_min.data() + static_cast<std::size_t>(v + 1) * w,
                out);
      for (int dv = std::max(0, v - band); dv <= std::min(h - 1, v + band); ++dv) {
        const float* in = row_min.data() + static_cast<std::size_t>(dv) * w;
        for (int u = 0; u < w; ++u) out[u] = std::min(out[u], in[u]);
      }
    }
    const float jump = sensor.discontinuity_m, jump_rel = 1.0f - sensor.discontinuity_rel;
    for (std::size_t i = 0; i < n; ++i) {
      // z - (jump + rel z) = (1 - rel) z - jump; an empty pixel (z = inf) never compares true here.
      if (depth[i] < jump_rel * hits[i].z - jump) frame.depth_mm[i] = 0;
    }
  }
  return frame;
}

}  // namespace mfot::sim
