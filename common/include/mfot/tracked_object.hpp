#pragma once
// What the ObjectManager keeps for each live object besides what it publishes (ManagedObject): one record per id,
// so that an object that goes (retired, joined, re-identified under another id) takes everything kept for it with
// it (ObjectManager::forget). The steps named are ObjectManager::process()'s.

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "mfot/model_updater.hpp"
#include "mfot/reidentification.hpp"
#include "mfot/types.hpp"

namespace mfot {

// Step 7 (split): one part of an object seen in parts, followed from frame to frame: its centroid (camera frame)
// last frame, and where and at which object pose it was first seen apart (JoinSplitOptions::split_min_departure).
struct SplitPart {
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
  Eigen::Vector3f first_centroid = Eigen::Vector3f::Zero();
  Pose first_pose;
};

struct TrackedObject {
  std::unique_ptr<ModelUpdater> updater;  // step 3: its own seeded updater (model_update.seed + id)
  ColorHistogram first_seen{};            // step 6: its model's colours when created (re-identification)
  // Step 7: the discovery split it was born from; objects born from one split are siblings (join by motion and the
  // discovery's confirmation only look at siblings).
  std::uint64_t birth = 0;
  bool born_unknown = false;           // step 6: it took no remembered id at birth: matched again as it grows
  std::optional<Pose> pose_before;     // step 1: its pose before this frame's estimate, when held (it may be carried)
  float model_radius = 0.f;            // step 1: its model's farthest point from its origin this frame, metres
  int split_streak = 0;                // step 7: frames in a row it lay in parts apart
  Pose split_pose;                     // step 7: its pose the last frame it lay in parts ...
  std::vector<SplitPart> split_parts;  // ... and those parts (empty: not in parts)
  // Step 7: where it was born (camera frame) while the discovery's confirmation still looks at it (nullopt: no more).
  std::optional<Eigen::Vector3f> confirm_born_at;
};

}  // namespace mfot
