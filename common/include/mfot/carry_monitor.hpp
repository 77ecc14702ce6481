#pragma once
// Objects carried while hidden (a departure from the thesis, whose filters follow whatever covers an
// object; README "Where mfot departs from the thesis"): a box that a hand grips, lifts and turns is
// hidden behind that hand for a second or more (`rotate`: 30-45 frames, up to 94 % of its model
// occluded, while it turns 50 degrees). Its tracker can only hold it (TrackingStep), so its pose
// would wait where it was last seen. When, before it was hidden, it moved rigidly with an object
// touching it, its pose follows that carrier's motion while it is hidden:
//   pose_t = carrier_t * carrier_k^-1 * pose_k,  k = the last frame it was seen.
// Steps of update(), per frame:
//   1. for every pair of objects seen this frame (not hidden, not stale) whose models touch (the
//      caller's test), each one's pose in the other's frame: the pair's watch counts the frames in a
//      row it stayed within translation / rotation_deg of what it was `frames` seen frames before (a
//      sliding window, so that a grip held for seconds, over which the two estimates drift apart by
//      more than the tolerance, still counts) and notes whether the other moved min_motion or turned
//      min_turn_deg since the watch began; beyond the tolerance, or no longer touching, the watch
//      starts over. Watches of hidden objects wait (neither counted
//      nor reset) until they are seen again;
//   2. a hidden object is carried by the seen neighbour whose watch ran at least `frames` frames with
//      that motion (the longest such watch; ties: the lower id);
//   3. its pose is that neighbour's pose composed with their relative pose of the object's last seen
//      frame.
// Deterministic, no draws. Non-copyable: it owns the watches.

#include "mfot/types.hpp"

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace mfot {

// Member defaults: off (the thesis); the merger and mfot-inprocess fill every field from
// configs/default.yaml (merger.carry).
struct CarryOptions {
  int frames = 0;                   // [0, 10000]; 0 = off
  float translation = 0.03f;        // metres (0, 0.5]: a hand's estimate wobbles by a centimetre or two
  float rotation_deg = 15.f;        // (0, 90]
  float min_motion = 0.03f;         // metres (0, 1]
  float min_turn_deg = 10.f;        // (0, 180]
  float contact_distance = 0.02f;   // the caller's touch test: model points this close, metres (0, 0.1]
  void validate() const;            // throws std::invalid_argument naming the field
};

class CarryMonitor {
 public:
  struct Object {
    std::int32_t id = 0;
    Pose pose;            // this frame's estimate, object -> camera
    bool hidden = false;  // its tracker held it this frame (nothing of it to score)
  };
  struct Carried {
    std::int32_t id = 0;
    std::int32_t carrier = 0;
    Pose pose;            // where the carrier's motion put it
  };
  using TouchTest = std::function<bool(std::int32_t, std::int32_t)>;

  explicit CarryMonitor(const CarryOptions& options = {});
  CarryMonitor(const CarryMonitor&) = delete;
  CarryMonitor& operator=(const CarryMonitor&) = delete;

  const CarryOptions& options() const { return options_; }

  // objects: every object with an estimate this frame, ids unique. touch(a, b): whether the two
  // objects' models touch at their poses; asked once per pair of seen objects. Returns the carried
  // hidden objects (ascending id); nothing while options().frames is 0.
  const std::vector<Carried>& update(std::span<const Object> objects, const TouchTest& touch);
  // The object is gone (retired, joined): its watches go too.
  void forget(std::int32_t id);

 private:
  struct Watch {
    // The object's pose in the neighbour's frame over the last `frames` seen frames, oldest first.
    std::deque<Eigen::Isometry3f> recent;
    Pose neighbour_at_start;
    Eigen::Isometry3f last_seen = Eigen::Isometry3f::Identity();  // the latest seen relative pose
    int frames = 0;
    bool neighbour_moved = false;
  };
  void observe(const Object& object, const Object& neighbour);

  CarryOptions options_;
  std::map<std::pair<std::int32_t, std::int32_t>, Watch> watches_;  // (object, neighbour)
  std::vector<Carried> carried_;
};

}  // namespace mfot
