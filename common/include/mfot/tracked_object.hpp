#pragma once
// What the ObjectManager keeps for each live object besides what it publishes (ManagedObject): one record per id,
// so that an object that goes (retired, joined, re-identified under another id) takes everything kept for it with
// it (ObjectManager::forget). The steps named are ObjectManager::process()'s.

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "mfot/join_split.hpp"
#include "mfot/model_updater.hpp"
#include "mfot/reidentification.hpp"
#include "mfot/types.hpp"

namespace mfot {

struct TrackedObject {
  std::unique_ptr<ModelUpdater> updater;  // step 3: its own seeded updater (model_update.seed + id)
  ColorHistogram first_seen{};            // step 6: its model's colours when created (re-identification)
  // Step 7: the discovery split it was born from; objects born from one split are siblings (join by motion and the
  // discovery's confirmation only look at siblings).
  std::uint64_t birth = 0;
  bool born_unknown = false;        // step 6: it took no remembered id at birth: matched again as it grows
  std::optional<Pose> pose_before;  // step 1: its pose before this frame's estimate, when held (it may be carried)
  float model_radius = 0.f;         // step 1: its model's farthest point from its origin this frame, metres
  SplitWatch split;                 // step 7: PartSplit's watch of its parts
  // Step 7: where it was born (camera frame) while the discovery's confirmation still looks at it (nullopt: no more).
  std::optional<Eigen::Vector3f> confirm_born_at;
};

}  // namespace mfot
