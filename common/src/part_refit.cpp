// Grown parts re-fitted on the first view (steps in the header).

#include "mfot/part_refit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "mfot/option_range.hpp"
#include "mfot/point_scatter.hpp"

namespace mfot {

void PartRefitOptions::validate(const std::string& owner) const {
  const auto check = [&](const char* field, auto value, double low, double high) {
    require_in_range(owner.c_str(), field, value, low, high, false);
  };
  check("min_points", min_points, 3, 1000000);
  check("min_spread", min_spread, 0.0, 1.0);
  check("min_coverage", min_coverage, 0.0, 1.0);
  check("min_rotation", min_rotation, 0.0, std::numbers::pi);
  check("min_translation", min_translation, 0.0, 1.0);
  check("min_held_rotation", min_held_rotation, 0.0, 1.0);
  icp.validate(owner + ".icp");
  if (icp.iterations == 0) throw std::invalid_argument(owner + ".icp.iterations must be > 0");
}

namespace {

const PartRefitOptions& validated(const PartRefitOptions& options) {
  options.validate();
  return options;
}

// The second largest standard deviation of the points' positions (0 with fewer than 3).
float second_spread(std::span<const Eigen::Vector3f> points) {
  if (points.size() < 3) return 0.f;
  PointScatter scatter;
  for (const Eigen::Vector3f& p : points) scatter.add(p);
  return static_cast<float>(scatter.spreads()(1));
}

}  // namespace

// Cells of the pairing distance, as the ICPs' own hashes.
PartRefit::PartRefit(const PartRefitOptions& options)
    : options_(validated(options)),
      model_hash_(options.icp.max_distance),
      segmented_hash_(options.icp.max_distance),
      first_view_icp_(options.icp),
      part_icp_(options.icp) {}

std::size_t PartRefit::refit(std::span<const Eigen::Vector3f> segmented, std::span<Eigen::Vector3f> model,
                             std::span<const std::uint32_t> part_ends, const Pose& estimate) {
  if (part_ends.empty() || part_ends.back() != model.size() || !std::is_sorted(part_ends.begin(), part_ends.end())) {
    throw std::invalid_argument("PartRefit::refit: part_ends must ascend to the model's " +
                                std::to_string(model.size()) + " points");
  }
  if (part_ends.size() < 2 || part_ends.front() == 0) return 0;
  // 1. each scene point to the part of its nearest model point
  model_hash_.build({model.data(), model.size()});
  part_scene_.resize(part_ends.size());
  for (auto& points : part_scene_) points.clear();
  const Eigen::Isometry3f to_object = estimate.isometry().inverse();
  segmented_local_.clear();
  for (const Eigen::Vector3f& p : segmented) segmented_local_.push_back(to_object * p);
  for (std::size_t i = 0; i < segmented.size(); ++i) {
    const Eigen::Vector3f& p = segmented[i];
    // The segmented points mostly lie within half the radius of the model: looked for there first.
    const int nearest = model_hash_.nearest_near_first(segmented_local_[i], options_.icp.max_distance);
    if (nearest < 0) continue;
    const auto part = static_cast<std::size_t>(
        std::upper_bound(part_ends.begin(), part_ends.end(), static_cast<std::uint32_t>(nearest)) - part_ends.begin());
    part_scene_[part].push_back(p);
  }
  // 2. parts seen well enough (the coverage index is built once a part gets that far)
  bool segmented_indexed = false;
  const auto seen_well = [&](std::size_t part) {
    if (part_scene_[part].size() < static_cast<std::size_t>(options_.min_points) ||
        second_spread(part_scene_[part]) < options_.min_spread) {
      return false;
    }
    if (!segmented_indexed) {
      segmented_hash_.build(segmented_local_);
      segmented_indexed = true;
    }
    const std::uint32_t begin = part == 0 ? 0 : part_ends[part - 1];
    std::size_t covered = 0;
    for (std::uint32_t k = begin; k < part_ends[part]; ++k) {
      covered += segmented_hash_.any_within(model[k], options_.icp.max_distance) ? 1 : 0;
    }
    return static_cast<float>(covered) >= options_.min_coverage * static_cast<float>(part_ends[part] - begin);
  };
  if (!seen_well(0)) return 0;
  seen_parts_.clear();
  for (std::size_t part = 1; part < part_ends.size(); ++part) {
    if (seen_well(part)) seen_parts_.push_back(part);
  }
  if (seen_parts_.empty()) return 0;  // nothing to re-fit: the first view's registration would go unused
  // 3. the pose the first view gives
  const IcpResult first_view = first_view_icp_.refine(part_scene_[0], model.subspan(0, part_ends[0]), estimate);
  if (!first_view.refined) return 0;
  const Eigen::Isometry3f first_view_pose = first_view.pose.isometry();
  const bool keeps_held = options_.min_held_rotation > 0.f;
  const Eigen::Matrix3d first_view_held =
      keeps_held ? first_view_rotations(part_scene_[0], model, part_ends[0], first_view.pose)
                 : Eigen::Matrix3d::Identity();
  // 4.-6. each grown part's misplacement, undone
  std::size_t moved = 0;
  for (const std::size_t part : seen_parts_) {
    const std::span<Eigen::Vector3f> points = model.subspan(part_ends[part - 1], part_ends[part] - part_ends[part - 1]);
    const IcpResult fitted = part_icp_.refine(part_scene_[part], points, first_view.pose);
    if (!fitted.refined) continue;
    Eigen::Isometry3f misplacement = first_view_pose.inverse() * fitted.pose.isometry();
    if (keeps_held) {
      const Eigen::Vector3d held =
          first_view_held * rotation_vector(Eigen::AngleAxisf(misplacement.linear())).cast<double>();
      Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
      for (const Eigen::Vector3f& p : points) centroid += p;
      centroid /= static_cast<float>(points.size());
      const Eigen::Vector3f centroid_moved = misplacement * centroid;
      const double angle = held.norm();
      misplacement.linear() =
          angle > 0.0 ? Eigen::AngleAxisf(static_cast<float>(angle), (held / angle).cast<float>()).toRotationMatrix()
                      : Eigen::Matrix3f::Identity();
      misplacement.translation() = centroid_moved - misplacement.linear() * centroid;
    }
    const float rotation = Eigen::AngleAxisf(misplacement.linear()).angle();
    if (rotation < options_.min_rotation && misplacement.translation().norm() < options_.min_translation) continue;
    for (Eigen::Vector3f& p : points) p = misplacement * p;
    ++moved;
  }
  return moved;
}

Eigen::Matrix3d PartRefit::first_view_rotations(std::span<const Eigen::Vector3f> scene,
                                                std::span<const Eigen::Vector3f> model, std::uint32_t first_view_end,
                                                const Pose& pose) {
  const float radius = options_.icp.max_distance;
  std::vector<Eigen::Vector3f>& normals = first_view_normals(model.first(first_view_end));
  const auto normal_at = [&](std::uint32_t k) -> const Eigen::Vector3f& {
    Eigen::Vector3f& normal = normals[k];
    if (std::isnan(normal.x())) {
      neighbours_.clear();  // radius_search appends
      model_hash_.radius_search(model[k], radius, neighbours_);
      PointScatter scatter;
      for (const int j : neighbours_) {
        if (static_cast<std::uint32_t>(j) < first_view_end) scatter.add(model[static_cast<std::size_t>(j)]);
      }
      // A point without a plane around it (fewer than 3 first-view neighbours) pairs along no normal.
      normal = scatter.count() >= 3 ? Eigen::Vector3f(scatter.least_spread_direction().cast<float>())
                                    : Eigen::Vector3f::Zero();
    }
    return normal;
  };
  // Point-to-plane normal equations over (rotation, translation) in the object frame, per pair:
  // a = (m x n, n), the change of the pair's distance along n per unit of each.
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  std::size_t pairs = 0;
  const Eigen::Isometry3f to_object = pose.isometry().inverse();
  for (const Eigen::Vector3f& p : scene) {
    const int nearest = model_hash_.nearest(to_object * p, radius);
    if (nearest < 0 || static_cast<std::uint32_t>(nearest) >= first_view_end) continue;
    const Eigen::Vector3f& n = normal_at(static_cast<std::uint32_t>(nearest));
    Eigen::Matrix<double, 6, 1> a;
    a << model[static_cast<std::size_t>(nearest)].cross(n).cast<double>(), n.cast<double>();
    information.noalias() += a * a.transpose();
    ++pairs;
  }
  if (pairs == 0) return Eigen::Matrix3d::Zero();
  information /= static_cast<double>(pairs);
  // The translation marginalised (Schur complement; its pseudo-inverse: a single face holds one direction).
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> translation(information.bottomRightCorner<3, 3>());
  const double largest = translation.eigenvalues().maxCoeff();
  Eigen::Vector3d inverse_values = Eigen::Vector3d::Zero();
  for (int i = 0; i < 3; ++i) {
    if (translation.eigenvalues()(i) > 1e-9 * largest) inverse_values(i) = 1.0 / translation.eigenvalues()(i);
  }
  const Eigen::Matrix3d translation_inverse =
      translation.eigenvectors() * inverse_values.asDiagonal() * translation.eigenvectors().transpose();
  const Eigen::Matrix3d rotation_information =
      information.topLeftCorner<3, 3>() -
      information.topRightCorner<3, 3>() * translation_inverse * information.bottomLeftCorner<3, 3>();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> rotations(rotation_information);
  const Eigen::Vector3d levers = rotations.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  Eigen::Matrix3d held = Eigen::Matrix3d::Zero();
  for (int i = 0; i < 3; ++i) {
    if (levers(i) > 0.0 && levers(i) >= options_.min_held_rotation * levers.maxCoeff()) {
      held += rotations.eigenvectors().col(i) * rotations.eigenvectors().col(i).transpose();
    }
  }
  return held;  // the projector onto the held rotations
}

std::vector<Eigen::Vector3f>& PartRefit::first_view_normals(std::span<const Eigen::Vector3f> first_view) {
  const auto same = [&](const NormalCache& cached) {
    return std::equal(first_view.begin(), first_view.end(), cached.points.begin(), cached.points.end());
  };
  auto found = std::find_if(normal_cache_.begin(), normal_cache_.end(), same);
  if (found == normal_cache_.end()) {
    // A first view not seen lately: another object's, or this one's thinned. The oldest entry makes way.
    if (normal_cache_.size() >= kNormalCacheSize) normal_cache_.erase(normal_cache_.begin());
    normal_cache_.push_back(
        {std::vector<Eigen::Vector3f>(first_view.begin(), first_view.end()),
         std::vector<Eigen::Vector3f>(first_view.size(),
                                      Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()))});
    found = normal_cache_.end() - 1;
  }
  return found->normals;
}

}  // namespace mfot
