#include <cmath>
#include <stdexcept>
#include <string>

#include "mfot/point_scatter.hpp"
#include "mfot/preprocessing.hpp"

namespace mfot {

namespace {

void require(bool ok, const char* field, const std::string& range) {
  if (!ok) throw std::invalid_argument(std::string("PlaneFitOptions.") + field + " must be " + range);
}

// Uniform index in [0, n) from 64 random bits (multiply-shift; bias below 2^-32 for the sizes
// used), identical on every platform unlike std::uniform_int_distribution.
std::size_t uniform_index(std::mt19937_64& rng, std::size_t n) {
  const std::uint64_t high = rng() >> 32;
  return static_cast<std::size_t>((high * static_cast<std::uint64_t>(n)) >> 32);
}

// Plane through the three points with its normal towards the origin; invalid when degenerate.
TablePlane plane_through(const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& c) {
  TablePlane plane;
  Eigen::Vector3f normal = (b - a).cross(c - a);
  const float norm = normal.norm();
  if (!(norm > 1e-9f)) return plane;
  normal /= norm;
  float offset = -normal.dot(a);
  if (offset < 0.f) {
    normal = -normal;
    offset = -offset;
  }
  plane.coefficients << normal, offset;
  plane.valid = true;
  return plane;
}

}  // namespace

void PlaneFitOptions::validate() const {
  require(iterations >= 1 && iterations <= 100000, "iterations", "in [1, 100000]");
  require(sample_points >= 3 && sample_points <= 1000000, "sample_points", "in [3, 1000000]");
  require(std::isfinite(inlier_distance) && inlier_distance > 0.f && inlier_distance <= 0.5f, "inlier_distance",
          "in (0, 0.5] metres");
  require(std::isfinite(min_inlier_share) && min_inlier_share > 0.f && min_inlier_share <= 1.f, "min_inlier_share",
          "in (0, 1]");
}

PlaneFitter::PlaneFitter(PlaneFitOptions options) : options_(options), rng_(options.seed) { options_.validate(); }

TablePlane PlaneFitter::fit(std::span<const Eigen::Vector3f> points, float* inlier_share) {
  if (inlier_share) *inlier_share = 0.f;
  const std::size_t n = points.size();
  if (n < 3) return {};

  // Hypotheses are scored on an even-stride sample: raster-ordered input makes it spatially even.
  const std::size_t m = std::min<std::size_t>(n, static_cast<std::size_t>(options_.sample_points));
  sample_.resize(m);
  for (std::size_t i = 0; i < m; ++i) sample_[i] = points[i * n / m];

  const float band = options_.inlier_distance;
  TablePlane best;
  std::size_t best_count = 0;
  for (int it = 0; it < options_.iterations; ++it) {
    const std::size_t i0 = uniform_index(rng_, m);
    const std::size_t i1 = uniform_index(rng_, m);
    const std::size_t i2 = uniform_index(rng_, m);
    if (i0 == i1 || i1 == i2 || i0 == i2) continue;
    const TablePlane hypothesis = plane_through(sample_[i0], sample_[i1], sample_[i2]);
    if (!hypothesis.valid) continue;
    const Eigen::Vector3f normal = hypothesis.coefficients.head<3>();
    const float offset = hypothesis.coefficients[3];
    std::size_t count = 0;
    for (const Eigen::Vector3f& p : sample_) count += std::abs(normal.dot(p) + offset) < band ? 1 : 0;
    if (count > best_count) {
      best_count = count;
      best = hypothesis;
    }
  }
  if (!best.valid) return {};

  // Least-squares refinement: the plane through the inliers' centroid normal to their direction
  // of least spread.
  const Eigen::Vector3f normal = best.coefficients.head<3>();
  const float offset = best.coefficients[3];
  PointScatter band_points;
  for (const Eigen::Vector3f& p : points) {
    if (std::abs(normal.dot(p) + offset) < band) band_points.add(p);
  }
  if (band_points.count() >= 3) {
    const Eigen::Vector3d centroid = band_points.centroid();
    Eigen::Vector3d refined_normal = band_points.least_spread_direction();
    if (refined_normal.dot(normal.cast<double>()) < 0.0) refined_normal = -refined_normal;
    double refined_offset = -refined_normal.dot(centroid);
    if (refined_offset < 0.0) {
      refined_normal = -refined_normal;
      refined_offset = -refined_offset;
    }
    best.coefficients << refined_normal.cast<float>(), static_cast<float>(refined_offset);
  }

  const Eigen::Vector3f final_normal = best.coefficients.head<3>();
  const float final_offset = best.coefficients[3];
  std::size_t inliers = 0;
  for (const Eigen::Vector3f& p : points) inliers += std::abs(final_normal.dot(p) + final_offset) < band ? 1 : 0;
  const float share = static_cast<float>(inliers) / static_cast<float>(n);
  if (inlier_share) *inlier_share = share;
  if (share < options_.min_inlier_share) return {};
  return best;
}

}  // namespace mfot
