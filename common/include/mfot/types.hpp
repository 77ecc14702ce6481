#pragma once
// Plain data types shared by the whole tracking core. Units: metres, radians.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <vector>

namespace mfot {

// The largest object id anything gives or takes (ObjectManager's ids, ids received on the wire): ids
// are int32 on the wire, and a million objects in one run is far beyond any scene; an id above it
// received from outside is refused, so no id counter can overflow.
inline constexpr std::int32_t kMaxObjectId = 1'000'000;

struct Rgb8 {
  std::uint8_t r = 0, g = 0, b = 0;
  friend bool operator==(const Rgb8&, const Rgb8&) = default;
};

// A coloured point set (structure of arrays keeps positions contiguous for the hot loops).
struct ColoredCloud {
  std::vector<Eigen::Vector3f> positions;  // metres
  std::vector<Rgb8> colors;                // same length as positions

  std::size_t size() const { return positions.size(); }
  bool empty() const { return positions.empty(); }
  void clear() {
    positions.clear();
    colors.clear();
  }
  void reserve(std::size_t n) {
    positions.reserve(n);
    colors.reserve(n);
  }
  void push_back(const Eigen::Vector3f& p, Rgb8 c) {
    positions.push_back(p);
    colors.push_back(c);
  }
};

// Rigid pose, object frame -> camera frame.
struct Pose {
  Eigen::Vector3f translation = Eigen::Vector3f::Zero();
  Eigen::Quaternionf rotation = Eigen::Quaternionf::Identity();  // unit

  Eigen::Isometry3f isometry() const {
    Eigen::Isometry3f t = Eigen::Isometry3f::Identity();
    t.linear() = rotation.toRotationMatrix();
    t.translation() = translation;
    return t;
  }
  static Pose from_isometry(const Eigen::Isometry3f& t) {
    Pose p;
    p.translation = t.translation();
    p.rotation = Eigen::Quaternionf(t.rotation()).normalized();
    return p;
  }
  Pose inverse() const { return from_isometry(isometry().inverse()); }
};

// A turn as its rotation vector (angle times unit axis, radians): turns compared or projected as vectors.
inline Eigen::Vector3f rotation_vector(const Eigen::AngleAxisf& turn) { return turn.angle() * turn.axis(); }

// 6-vector pose state (x, y, z, roll, pitch, yaw) used for diffusion and velocity (2.12-2.15).
using PoseVector = Eigen::Matrix<float, 6, 1>;

}  // namespace mfot
