#pragma once
// Whether two objects touch: some point of one's model, placed at its pose, lies within a distance of
// some point of the other's. The contact test behind joining rigid parts (RigidPartJoin), carrying hidden
// objects (CarryMonitor), choosing companions (companion_motion.hpp) and parts entering the view with an object
// (ObjectManager step 6); not a step of the thesis, whose
// objects never interact. Steps of touching():
//   1. a pair already tested this frame at this distance gives the same answer (the memo; new_frame() clears it);
//   2. bounding spheres: objects whose origins lie farther apart than their radii and the distance do not touch
//      (most pairs of a scene end here);
//   3. otherwise models_touch(): the first model's points hashed at the distance, the second's looked up.

#include <cstdint>
#include <map>
#include <tuple>
#include <vector>

#include "mfot/likelihood.hpp"
#include "mfot/spatial_hash.hpp"
#include "mfot/types.hpp"

namespace mfot {

// One object's model at a pose, for the contact test. model must outlive the call.
struct PlacedModel {
  std::int32_t id = 0;
  const ObjectModel* model = nullptr;  // object frame
  Pose pose;                           // object -> camera
  float radius = 0.f;                  // metres, >= the model's farthest point from its origin (step 2)
};

class ModelContact {
 public:
  ModelContact() = default;
  ModelContact(const ModelContact&) = delete;
  ModelContact& operator=(const ModelContact&) = delete;

  // Whether a point of b's model lies within distance (metres, > 0) of a point of a's model, both at their poses.
  // Not memoised.
  bool models_touch(const PlacedModel& a, const PlacedModel& b, float distance);
  // models_touch after steps 1 and 2; the pair's order does not matter (ids differ).
  bool touching(const PlacedModel& a, const PlacedModel& b, float distance);
  // The share ([0, 1]) of the smaller model's points (the first's when equal) within distance (metres, > 0) of the
  // other model's, both at their poses; 0 when their bounding spheres (radius + distance) do not meet. Not memoised.
  float overlap_share(const PlacedModel& a, const PlacedModel& b, float distance);
  // Forgets the memo: poses and models change between frames.
  void new_frame() { memo_.clear(); }

 private:
  // Step 2: whether the two bounding spheres, grown by distance, meet.
  static bool spheres_meet(const PlacedModel& a, const PlacedModel& b, float distance);
  // hash_ holds the model's points at its pose (camera frame), cells of distance.
  void hash_placed(const PlacedModel& placed, float distance);

  SpatialHash hash_{0.01f};
  std::vector<Eigen::Vector3f> points_;
  std::map<std::tuple<std::int32_t, std::int32_t, float>, bool> memo_;  // (lower id, higher id, distance)
};

}  // namespace mfot
