#include "mfot/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <tuple>

namespace mfot {

namespace {

constexpr float kSceneCell = 0.01f;  // metres: the scene index's cell, ~2 x the voxel leaf

const FittingDistanceOptions& validated(const FittingDistanceOptions& options) {
  options.validate();
  return options;
}

}  // namespace

// ---- fitting distance ------------------------------------------------------------------------

void FittingDistanceOptions::validate() const {
  if (!(occlusion_window > 0.f && occlusion_window <= 0.1f)) {
    throw std::invalid_argument("FittingDistanceOptions.occlusion_window must be in (0, 0.1], got " +
                                std::to_string(occlusion_window));
  }
  if (!(depth_margin >= 0.f && depth_margin <= 1.f)) {
    throw std::invalid_argument("FittingDistanceOptions.depth_margin must be in [0, 1] metres, got " +
                                std::to_string(depth_margin));
  }
}

FittingDistanceEvaluator::FittingDistanceEvaluator(const FittingDistanceOptions& options)
    : options_(validated(options)),
      scene_hash_(kSceneCell),
      occlusion_({.window = options.occlusion_window, .depth_margin = options.depth_margin}) {
  scene_hash_.build({});
}

void FittingDistanceEvaluator::set_scene(std::span<const Eigen::Vector3f> scene_points) {
  scene_.assign(scene_points.begin(), scene_points.end());
  scene_hash_.build(scene_);
  occlusion_.set_scene(scene_);
}

FittingDistance FittingDistanceEvaluator::evaluate(std::span<const Eigen::Vector3f> model_points,
                                                   const Pose& pose) const {
  Pose unit = pose;
  unit.rotation.normalize();
  const Eigen::Isometry3f to_camera = unit.isometry();
  FittingDistance result;
  result.model_points = model_points.size();
  if (model_points.empty()) return result;
  // Growing search radii; the last one is unbounded. The first radius that holds a scene point gives the
  // nearest of all (every point beyond it is further), so the radii set only the cost: the first, half a
  // cell (8 cells at most), already holds the nearest of most points of a fitted model.
  constexpr float kRadii[] = {0.5f * kSceneCell, 2 * kSceneCell, 8 * kSceneCell,
                              std::numeric_limits<float>::infinity()};
  double sum = 0.0;
  for (const auto& p : model_points) {
    const Eigen::Vector3f m = to_camera * p;
    if (options_.occlusion_test && occlusion_.occluded(m)) {
      ++result.occluded;
      continue;
    }
    float d2 = std::numeric_limits<float>::infinity();
    for (const float radius : kRadii) {
      if (scene_hash_.nearest(m, radius, &d2) >= 0) break;
    }
    sum += std::sqrt(static_cast<double>(d2));
  }
  result.mean = sum / static_cast<double>(model_points.size());
  return result;
}

// ---- segmentation accuracy -------------------------------------------------------------------

void SegmentationAccuracy::add_frame(std::span<const std::int32_t> predicted,
                                     std::span<const std::int32_t> ground_truth) {
  if (predicted.size() != ground_truth.size()) {
    throw std::invalid_argument("SegmentationAccuracy: predicted and ground-truth labels must have one size");
  }
  std::map<Pair, std::uint64_t> frame;
  for (std::size_t i = 0; i < predicted.size(); ++i) {
    if (predicted[i] < 0 || ground_truth[i] < 0)
      throw std::invalid_argument("SegmentationAccuracy: labels must be >= 0");
    ++frame[{predicted[i], ground_truth[i]}];
  }
  auto& pairs = frame_pairs_.emplace_back();
  for (const auto& [pair, count] : frame) {
    overlap_[pair] += count;
    pairs.emplace_back(pair, count);
  }
  frame_points_.push_back(predicted.size());
  total_points_ += predicted.size();
}

std::map<std::int32_t, std::int32_t> SegmentationAccuracy::mapping() const {
  std::map<std::int32_t, std::int32_t> map;
  std::vector<std::tuple<std::uint64_t, std::int32_t, std::int32_t>> candidates;
  for (const auto& [pair, count] : overlap_) {
    map.emplace(pair.first, pair.first == 0 ? 0 : kUnmatched);
    if (pair.first != 0 && pair.second != 0) candidates.emplace_back(count, pair.first, pair.second);
  }
  std::sort(candidates.begin(), candidates.end(), [](const auto& a, const auto& b) {
    if (std::get<0>(a) != std::get<0>(b)) return std::get<0>(a) > std::get<0>(b);
    if (std::get<1>(a) != std::get<1>(b)) return std::get<1>(a) < std::get<1>(b);
    return std::get<2>(a) < std::get<2>(b);
  });
  std::map<std::int32_t, bool> gt_taken;
  for (const auto& [count, predicted, truth] : candidates) {
    if (map[predicted] != kUnmatched || gt_taken[truth]) continue;
    map[predicted] = truth;
    gt_taken[truth] = true;
  }
  return map;
}

double SegmentationAccuracy::accuracy() const {
  if (total_points_ == 0) return 1.0;
  const auto map = mapping();
  std::uint64_t correct = 0;
  for (const auto& [pair, count] : overlap_) {
    if (map.at(pair.first) == pair.second) correct += count;
  }
  return static_cast<double>(correct) / static_cast<double>(total_points_);
}

std::vector<SegmentationAccuracy::Overlap> SegmentationAccuracy::overlaps() const {
  std::map<Pair, std::size_t> frames;
  for (const auto& pairs : frame_pairs_) {
    for (const auto& entry : pairs) ++frames[entry.first];
  }
  std::vector<Overlap> result;
  result.reserve(overlap_.size());
  for (const auto& [pair, count] : overlap_) result.push_back({pair.first, pair.second, count, frames.at(pair)});
  return result;
}

std::vector<double> SegmentationAccuracy::frame_accuracies() const {
  const auto map = mapping();
  std::vector<double> result;
  result.reserve(frame_pairs_.size());
  for (std::size_t f = 0; f < frame_pairs_.size(); ++f) {
    if (frame_points_[f] == 0) {
      result.push_back(1.0);
      continue;
    }
    std::uint64_t correct = 0;
    for (const auto& [pair, count] : frame_pairs_[f]) {
      if (map.at(pair.first) == pair.second) correct += count;
    }
    result.push_back(static_cast<double>(correct) / static_cast<double>(frame_points_[f]));
  }
  return result;
}

// ---- relative pose error ---------------------------------------------------------------------

namespace {

struct Motion {
  Eigen::Quaterniond rotation;
  Eigen::Vector3d translation;
};

Eigen::Quaterniond unit_rotation(const Pose& pose) { return pose.rotation.cast<double>().normalized(); }

// X_t X_t0^-1 with X = (R, t): rotation R_t R_t0^T, translation t_t - R_t R_t0^T t_t0.
Motion motion_from(const Pose& first, const Pose& current) {
  const Eigen::Quaterniond r = unit_rotation(current) * unit_rotation(first).conjugate();
  return {r, current.translation.cast<double>() - r * first.translation.cast<double>()};
}

}  // namespace

std::vector<PoseError> relative_pose_errors(std::span<const Pose> predicted, std::span<const Pose> ground_truth,
                                            const Eigen::Vector3f& symmetry_axis) {
  if (predicted.size() != ground_truth.size()) {
    throw std::invalid_argument("relative_pose_errors: predicted and ground-truth trajectories must have one size");
  }
  std::vector<PoseError> errors(predicted.size());
  if (predicted.empty()) return errors;
  // The object's own centre at t0 (the ground-truth origin, a physical point), camera frame.
  const Eigen::Vector3d centre = ground_truth.front().translation.cast<double>();
  // The symmetry axis at t0, camera frame.
  const bool symmetric = symmetry_axis.squaredNorm() > 0.f;
  const Eigen::Vector3d axis =
      symmetric ? (ground_truth.front().rotation.cast<double>() * symmetry_axis.cast<double>().normalized())
                : Eigen::Vector3d::Zero();
  for (std::size_t t = 0; t < predicted.size(); ++t) {
    const Motion p = motion_from(predicted.front(), predicted[t]);
    const Motion g = motion_from(ground_truth.front(), ground_truth[t]);
    const Eigen::Quaterniond delta = g.rotation.conjugate() * p.rotation;
    // Angle from the quaternion as 2 atan2(|v|, |w|): accurate for small angles, too.
    const double angle = 2.0 * std::atan2(delta.vec().norm(), std::abs(delta.w()));
    errors[t].translation_mm =
        ((p.rotation * centre + p.translation) - (g.rotation * centre + g.translation)).norm() * 1000.0;
    errors[t].translation_at_camera_mm = (p.translation - g.translation).norm() * 1000.0;
    errors[t].rotation_deg = angle * 180.0 / std::numbers::pi;
    errors[t].observable_rotation_deg = errors[t].rotation_deg;
    if (symmetric) {
      const Eigen::Vector3d carried_p = p.rotation * axis, carried_g = g.rotation * axis;
      errors[t].observable_rotation_deg =
          std::atan2(carried_p.cross(carried_g).norm(), carried_p.dot(carried_g)) * 180.0 / std::numbers::pi;
    }
  }
  return errors;
}

namespace {

double median_of(std::vector<double>& values) {
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

}  // namespace

PoseErrorSummary summarize(std::span<const PoseError> errors, const PoseErrorSummaryOptions& options) {
  PoseErrorSummary s;
  s.count = errors.size();
  if (errors.empty()) return s;
  std::vector<double> translations, rotations, observable;
  std::size_t over_t = 0, over_r = 0, over_either = 0;
  for (const auto& e : errors) {
    translations.push_back(e.translation_mm);
    rotations.push_back(e.rotation_deg);
    observable.push_back(e.observable_rotation_deg);
    s.observable_rotation_max_deg = std::max(s.observable_rotation_max_deg, e.observable_rotation_deg);
    s.translation_mean_mm += e.translation_mm;
    s.rotation_mean_deg += e.rotation_deg;
    s.translation_max_mm = std::max(s.translation_max_mm, e.translation_mm);
    s.rotation_max_deg = std::max(s.rotation_max_deg, e.rotation_deg);
    const bool t_over = e.translation_mm > options.translation_threshold_mm;
    const bool r_over = e.rotation_deg > options.rotation_threshold_deg;
    over_t += t_over;
    over_r += r_over;
    over_either += t_over || r_over;
  }
  const auto n = static_cast<double>(errors.size());
  s.translation_mean_mm /= n;
  s.rotation_mean_deg /= n;
  s.translation_median_mm = median_of(translations);
  s.rotation_median_deg = median_of(rotations);
  s.observable_rotation_median_deg = median_of(observable);
  s.share_translation_over = static_cast<double>(over_t) / n;
  s.share_rotation_over = static_cast<double>(over_r) / n;
  s.share_either_over = static_cast<double>(over_either) / n;
  return s;
}

}  // namespace mfot

namespace mfot {

void SegmentMatchOptions::validate() const {
  if (!(found_iou > 0.0 && found_iou <= 1.0)) {
    throw std::invalid_argument("SegmentMatchOptions.found_iou must be in (0, 1], got " + std::to_string(found_iou));
  }
  if (!(part_share > 0.0 && part_share <= 0.5)) {
    throw std::invalid_argument("SegmentMatchOptions.part_share must be in (0, 0.5], got " +
                                std::to_string(part_share));
  }
}

SegmentMatch match_segments(std::span<const std::int32_t> truth, std::span<const std::int32_t> predicted,
                            const SegmentMatchOptions& options) {
  options.validate();
  if (truth.size() != predicted.size()) {
    throw std::invalid_argument("match_segments: " + std::to_string(truth.size()) + " truth labels but " +
                                std::to_string(predicted.size()) + " predicted");
  }
  std::map<std::int32_t, std::size_t> segment_size, object_size, object_background;
  std::map<std::pair<std::int32_t, std::int32_t>, std::size_t> overlap;  // (segment, object)
  for (std::size_t i = 0; i < truth.size(); ++i) {
    if (truth[i] != 0) ++segment_size[truth[i]];
    if (predicted[i] != 0) {
      ++object_size[predicted[i]];
      if (truth[i] == 0) ++object_background[predicted[i]];
    }
    if (truth[i] != 0 && predicted[i] != 0) ++overlap[{truth[i], predicted[i]}];
  }
  SegmentMatch m;
  m.segments = segment_size.size();
  m.objects = object_size.size();
  // Per segment: its best IoU, its largest object and the objects holding a part of it.
  std::map<std::int32_t, std::int32_t> largest_object;
  std::map<std::int32_t, std::size_t> largest_count, parts;
  std::map<std::int32_t, double> best_iou;
  for (const auto& [key, count] : overlap) {
    const auto [segment, object] = key;
    const double iou =
        static_cast<double>(count) / static_cast<double>(segment_size[segment] + object_size[object] - count);
    best_iou[segment] = std::max(best_iou[segment], iou);
    if (count > largest_count[segment]) {
      largest_count[segment] = count;
      largest_object[segment] = object;
    }
    if (static_cast<double>(count) >= options.part_share * static_cast<double>(segment_size[segment])) ++parts[segment];
  }
  double weighted = 0.0, total = 0.0;
  for (const auto& [segment, size] : segment_size) {
    const double iou = best_iou[segment];
    if (iou >= options.found_iou) ++m.found;
    weighted += static_cast<double>(size) * iou;
    total += static_cast<double>(size);
    if (parts[segment] >= 2) ++m.split;
    const auto largest = largest_object.find(segment);
    if (largest == largest_object.end()) continue;
    for (const auto& [other, other_size] : segment_size) {
      if (other == segment) continue;
      const auto it = overlap.find({other, largest->second});
      if (it != overlap.end() && 2 * it->second > other_size) {
        ++m.merged;
        break;
      }
    }
  }
  m.weighted_overlap = total > 0.0 ? weighted / total : 1.0;
  for (const auto& [object, size] : object_size) {
    if (2 * object_background[object] > size) ++m.spurious;
  }
  return m;
}

}  // namespace mfot
