#include "mfot/join_split.hpp"

#include <algorithm>
#include <numbers>
#include <stdexcept>

#include "mfot/option_range.hpp"

namespace mfot {

void JoinSplitOptions::validate() const {
  const auto in = [](const char* field, auto value, double low, double high, bool low_open) {
    require_in_range("JoinSplitOptions", field, value, low, high, low_open);
  };
  in("join_frames", join_frames, 0, 10000, false);
  in("join_translation", join_translation, 0, 0.1, true);
  in("join_rotation_deg", join_rotation_deg, 0, 45, true);
  in("join_min_motion", join_min_motion, 0, 1, true);
  in("join_min_turn_deg", join_min_turn_deg, 0, 180, true);
  in("join_contact_distance", join_contact_distance, 0, 0.1, true);
  in("split_frames", split_frames, 0, 10000, false);
  in("split_min_share", split_min_share, 0, 0.5, true);
  in("split_min_gap", split_min_gap, 0, 1, false);
  in("split_max_occluded", split_max_occluded, 0, 1, false);
  in("split_min_departure", split_min_departure, 0, 1, false);
  in("overlap_frames", overlap_frames, 0, 10000, false);
  in("overlap_share", overlap_share, 0, 1, true);
  if (split_min_departure > 0.f && split_min_gap <= 0.f) {
    throw std::invalid_argument(
        "JoinSplitOptions.split_min_departure needs split_min_gap > 0: parts are followed from "
        "frame to frame within split_min_gap");
  }
}

RigidPartJoin::RigidPartJoin(const JoinSplitOptions& options) : options_((options.validate(), options)) {}

std::vector<std::pair<std::int32_t, std::int32_t>> RigidPartJoin::update(
    std::span<const JoinCandidate> objects, const std::function<bool(std::int32_t, std::int32_t)>& touch) {
  const JoinSplitOptions& o = options_;
  const float max_angle = o.join_rotation_deg * std::numbers::pi_v<float> / 180.f;
  const float min_turn = o.join_min_turn_deg * std::numbers::pi_v<float> / 180.f;
  std::vector<std::pair<std::int32_t, std::int32_t>> joins;
  for (auto a = objects.begin(); a != objects.end(); ++a) {
    for (auto b = std::next(a); b != objects.end(); ++b) {
      const JoinCandidate& first = *a;
      const JoinCandidate& second = *b;
      if (first.birth != second.birth || first.stale || second.stale) continue;
      const Eigen::Isometry3f relative = first.pose.isometry().inverse() * second.pose.isometry();
      PairWatch& watch = pairs_[{first.id, second.id}];
      const Eigen::Quaternionf turn(watch.relative.linear().transpose() * relative.linear());
      const bool kept = watch.frames > 0 &&
                        (relative.translation() - watch.relative.translation()).norm() <= o.join_translation &&
                        Eigen::AngleAxisf(turn).angle() <= max_angle;
      if (!kept) {
        watch = {relative, first.pose, 1};
        continue;
      }
      if (++watch.frames < o.join_frames) continue;
      const bool moved = (first.pose.translation - watch.start.translation).norm() >= o.join_min_motion ||
                         first.pose.rotation.angularDistance(watch.start.rotation) >= min_turn;
      if (moved && touch(first.id, second.id)) joins.emplace_back(first.id, second.id);
    }
  }
  return joins;
}

void RigidPartJoin::forget(std::int32_t id) {
  std::erase_if(pairs_, [id](const auto& entry) { return entry.first.first == id || entry.first.second == id; });
}

OverlapJoin::OverlapJoin(const JoinSplitOptions& options) : options_((options.validate(), options)) {}

std::vector<std::pair<std::int32_t, std::int32_t>> OverlapJoin::update(
    std::span<const OverlapCandidate> objects, const std::function<float(std::int32_t, std::int32_t)>& overlap) {
  std::vector<std::pair<std::int32_t, std::int32_t>> joins;
  for (auto a = objects.begin(); a != objects.end(); ++a) {
    for (auto b = std::next(a); b != objects.end(); ++b) {
      const auto key = std::make_pair(a->id, b->id);
      if (!a->seen || !b->seen || overlap(a->id, b->id) < options_.overlap_share) {
        frames_.erase(key);
        continue;
      }
      if (++frames_[key] < options_.overlap_frames) continue;
      joins.emplace_back(a->id, b->id);  // the lower id, the one known longest, is kept
    }
  }
  return joins;
}

void OverlapJoin::forget(std::int32_t id) {
  std::erase_if(frames_, [id](const auto& entry) { return entry.first.first == id || entry.first.second == id; });
}

PartSplit::PartSplit(const JoinSplitOptions& options, std::size_t min_object_points)
    : options_((options.validate(), options)), min_object_points_(min_object_points) {
  if (min_object_points < 1) throw std::invalid_argument("PartSplit: min_object_points must be >= 1");
}

bool PartSplit::update(const Pose& pose, bool stale, const std::map<std::int32_t, std::vector<int>>& clusters,
                       std::span<const Eigen::Vector3f> scene, const std::function<float()>& occluded_share,
                       SplitWatch& watch, std::vector<int>& own, std::vector<std::vector<int>>& leaving) {
  const JoinSplitOptions& o = options_;
  own.clear();
  leaving.clear();
  std::size_t total = 0;
  for (const auto& [cluster, points] : clusters) total += points.size();
  std::vector<const std::vector<int>*> large;
  for (const auto& [cluster, points] : clusters) {
    if (points.size() >= min_object_points_ &&
        static_cast<float>(points.size()) >= o.split_min_share * static_cast<float>(total)) {
      large.push_back(&points);
    }
  }
  bool apart = !stale && large.size() >= 2;
  if (apart && o.split_min_gap > 0.f) {
    // The two largest parts: no point of one within split_min_gap of the other.
    std::sort(large.begin(), large.end(), [](const auto* x, const auto* y) { return x->size() > y->size(); });
    first_.clear();
    for (const int i : *large[0]) first_.push_back(scene[static_cast<std::size_t>(i)]);
    gap_hash_ = SpatialHash(o.split_min_gap);
    gap_hash_.build(first_);
    for (const int i : *large[1]) {
      if (gap_hash_.any_within(scene[static_cast<std::size_t>(i)], o.split_min_gap)) {
        apart = false;
        break;
      }
    }
  }
  if (apart) apart = occluded_share() <= o.split_max_occluded;
  watch.streak = apart ? watch.streak + 1 : 0;
  const std::vector<SplitPart> parts_apart = follow(pose, watch, scene, apart ? large : decltype(large){});
  if (watch.streak < o.split_frames) return false;
  // The object keeps its largest part (first of equals); the others that departed from its motion leave.
  const auto largest =
      std::max_element(large.begin(), large.end(), [](const auto* x, const auto* y) { return x->size() < y->size(); });
  std::vector<const std::vector<int>*> departed;
  for (std::size_t k = 0; k < large.size(); ++k) {
    if (large[k] == *largest) continue;
    const SplitPart& part = parts_apart[k];
    const Eigen::Isometry3f since = pose.isometry() * part.first_pose.isometry().inverse();
    if ((since * part.first_centroid - part.centroid).norm() >= o.split_min_departure) departed.push_back(large[k]);
  }
  if (departed.empty()) return false;  // parts of one body so far: the streak goes on
  watch = SplitWatch{};
  for (const auto* points : large) {
    if (std::find(departed.begin(), departed.end(), points) == departed.end()) {
      own.insert(own.end(), points->begin(), points->end());
    }
  }
  std::sort(own.begin(), own.end());
  for (const auto* points : departed) leaving.push_back(*points);
  return true;
}

std::vector<SplitPart> PartSplit::follow(const Pose& pose, SplitWatch& watch, std::span<const Eigen::Vector3f> scene,
                                         std::span<const std::vector<int>* const> parts) const {
  if (parts.empty()) {  // not seen apart: nothing to follow
    watch.pose = Pose{};
    watch.parts.clear();
    return {};
  }
  // Last frame's part each part continues: its centroid, moved with the object or left where it was, is the nearest
  // within split_min_gap (parts lie that far apart); a part continuing none is first seen now.
  const Eigen::Isometry3f motion = pose.isometry() * watch.pose.isometry().inverse();
  std::vector<SplitPart> now;
  for (const std::vector<int>* points : parts) {
    SplitPart part;
    for (const int i : *points) part.centroid += scene[static_cast<std::size_t>(i)];
    part.centroid /= static_cast<float>(points->size());
    part.first_centroid = part.centroid;
    part.first_pose = pose;
    float best = options_.split_min_gap;
    for (const SplitPart& before : watch.parts) {
      const float distance =
          std::min((motion * before.centroid - part.centroid).norm(), (before.centroid - part.centroid).norm());
      if (distance < best) {
        best = distance;
        part.first_centroid = before.first_centroid;
        part.first_pose = before.first_pose;
      }
    }
    now.push_back(part);
  }
  watch.pose = pose;
  watch.parts = now;
  return now;
}

}  // namespace mfot
