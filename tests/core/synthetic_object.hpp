#pragma once
// Synthetic coloured objects for the core tests: box surfaces with coloured faces (optionally
// split into two colours per face), poses, occlusion and error measures.

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <vector>

#include "mfot/likelihood.hpp"
#include "mfot/smr_feature.hpp"
#include "mfot/types.hpp"

namespace mfot::test {

// Pure hues sit on the SMR hue representatives (0, 60, ..., 300 degrees): one chromatic bin each.
inline constexpr Rgb8 kRed{255, 0, 0};
inline constexpr Rgb8 kYellow{255, 255, 0};
inline constexpr Rgb8 kGreen{0, 255, 0};
inline constexpr Rgb8 kCyan{0, 255, 255};
inline constexpr Rgb8 kBlue{0, 0, 255};
inline constexpr Rgb8 kMagenta{255, 0, 255};
inline constexpr Rgb8 kWhite{235, 235, 235};
inline constexpr Rgb8 kBlack{20, 20, 20};

// Face order: -x, +x, -y, +y, -z, +z.
inline constexpr std::array<Rgb8, 6> kSixColours{kRed, kCyan, kYellow, kBlue, kGreen, kMagenta};

// Surface of a box centred on the origin with edge lengths `size`, sampled on a regular grid of
// `spacing` on each face, shifted by `phase` (in [0, 1), a fraction of the spacing) so that two
// samplings of the same box can share no point. Each face has colour face_colors[f]; when
// second_colors is given, the face half with positive first in-face coordinate takes
// second_colors[f] instead (a texture that breaks in-face symmetry).
inline ColoredCloud make_colored_box(const Eigen::Vector3f& size, float spacing,
                                     const std::array<Rgb8, 6>& face_colors = kSixColours,
                                     const std::array<Rgb8, 6>* second_colors = nullptr, float phase = 0.f) {
  ColoredCloud cloud;
  const Eigen::Vector3f half = 0.5f * size;
  for (int axis = 0; axis < 3; ++axis) {
    const int u_axis = (axis + 1) % 3;
    const int v_axis = (axis + 2) % 3;
    const int nu = std::max(1, static_cast<int>(std::floor(size[u_axis] / spacing)));
    const int nv = std::max(1, static_cast<int>(std::floor(size[v_axis] / spacing)));
    for (int side = 0; side < 2; ++side) {
      const int face = 2 * axis + side;
      for (int i = 0; i < nu; ++i) {
        for (int j = 0; j < nv; ++j) {
          Eigen::Vector3f p;
          p[axis] = side == 0 ? -half[axis] : half[axis];
          p[u_axis] = -half[u_axis] + (static_cast<float>(i) + 0.5f * phase + 0.25f) * size[u_axis] / nu;
          p[v_axis] = -half[v_axis] + (static_cast<float>(j) + 0.5f * phase + 0.25f) * size[v_axis] / nv;
          const bool second = second_colors != nullptr && p[u_axis] > 0.f;
          cloud.push_back(p, second ? (*second_colors)[face] : face_colors[face]);
        }
      }
    }
  }
  return cloud;
}

// The default test object: a 10 x 15 x 8 cm box with six face colours, about 1000 points at
// 8 mm spacing. textured = true splits every face into its colour and white or black.
inline const Eigen::Vector3f kTestObjectSize(0.10f, 0.15f, 0.08f);  // make_test_object's edge lengths, metres
inline ColoredCloud make_test_object(float phase = 0.f, float spacing = 0.008f, bool textured = false) {
  static constexpr std::array<Rgb8, 6> kSecond{kWhite, kBlack, kWhite, kBlack, kWhite, kBlack};
  return make_colored_box(kTestObjectSize, spacing, kSixColours, textured ? &kSecond : nullptr, phase);
}

// The outward normal of the face a point of a box cloud (make_colored_box with edge lengths size, object
// frame) lies on, along the face's axis: +-1 in one coordinate (no sample lies on two faces).
inline Eigen::Vector3f face_normal(const Eigen::Vector3f& p, const Eigen::Vector3f& size) {
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();
  for (int a = 0; a < 3; ++a) {
    if (std::abs(std::abs(p[a]) - 0.5f * size[a]) < 1e-4f) normal[a] = p[a] > 0.f ? 1.f : -1.f;
  }
  return normal;
}

// The points of a box cloud (make_colored_box with edge lengths size, object frame) on the faces
// that a camera at the origin sees when the box is at pose: its near side, camera frame.
inline ColoredCloud seen_from_origin(const ColoredCloud& box, const Eigen::Vector3f& size, const Pose& pose) {
  ColoredCloud seen;
  for (std::size_t k = 0; k < box.size(); ++k) {
    const Eigen::Vector3f& p = box.positions[k];
    const Eigen::Vector3f normal = face_normal(p, size);
    const Eigen::Vector3f at = pose.isometry() * p;
    if ((pose.rotation * normal).dot(at) < 0.f) seen.push_back(at, box.colors[k]);
  }
  return seen;
}

inline ObjectModel make_model(const ColoredCloud& cloud) {
  ObjectModel model;
  model.cloud = cloud;
  model.features = compute_smr(cloud.colors);
  return model;
}

inline ColoredCloud transformed(const ColoredCloud& cloud, const Pose& pose) {
  ColoredCloud out = cloud;
  const Eigen::Isometry3f t = pose.isometry();
  for (Eigen::Vector3f& p : out.positions) p = t * p;
  return out;
}

inline HypothesisData make_hypothesis(const ColoredCloud& camera_frame) {
  HypothesisData data;
  data.points = camera_frame.positions;
  data.colors = camera_frame.colors;
  data.features = compute_smr(camera_frame.colors);
  return data;
}

// Removes the `fraction` of points that lie farthest along `direction` (a planar occluder).
inline ColoredCloud occluded(const ColoredCloud& cloud, const Eigen::Vector3f& direction, float fraction) {
  std::vector<float> projections;
  projections.reserve(cloud.size());
  for (const Eigen::Vector3f& p : cloud.positions) projections.push_back(p.dot(direction));
  std::vector<float> sorted = projections;
  std::sort(sorted.begin(), sorted.end());
  const auto keep = static_cast<std::size_t>(std::lround((1.0f - fraction) * static_cast<float>(cloud.size())));
  const float threshold = keep < sorted.size() ? sorted[keep] : sorted.back() + 1.f;
  ColoredCloud out;
  for (std::size_t k = 0; k < cloud.size(); ++k) {
    if (projections[k] < threshold) out.push_back(cloud.positions[k], cloud.colors[k]);
  }
  return out;
}

inline Pose make_pose(const Eigen::Vector3f& translation, const Eigen::Vector3f& axis, float angle_rad) {
  Pose p;
  p.translation = translation;
  p.rotation = Eigen::Quaternionf(Eigen::AngleAxisf(angle_rad, axis.normalized()));
  return p;
}

inline float degrees(float radians) { return radians * 180.f / std::numbers::pi_v<float>; }
inline float radians(float degrees) { return degrees * std::numbers::pi_v<float> / 180.f; }

inline float translation_error(const Pose& a, const Pose& b) { return (a.translation - b.translation).norm(); }
// Angle of the relative rotation between two poses, radians.
inline float rotation_error(const Pose& a, const Pose& b) { return a.rotation.angularDistance(b.rotation); }

}  // namespace mfot::test
