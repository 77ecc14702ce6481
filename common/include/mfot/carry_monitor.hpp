#pragma once
// Objects carried while hidden (a departure from the thesis, whose filters follow whatever covers an
// object; docs/departures.md): a box that a hand grips, lifts and turns may be
// hidden behind that hand for a second or more, most of its model occluded while it turns. Its tracker can only hold it
// (TrackingStep), so its pose would wait where it was last seen. When, before it was hidden, it moved rigidly with an
// object touching it, its pose follows that carrier's motion while it is hidden:
//   pose_t = carrier_t * carrier_k^-1 * pose_k,  k = the last frame it was seen.
// Steps of update(), per frame:
//   1. for every pair of objects seen this frame (not hidden, not stale) whose models touch (the
//      caller's test), each one's pose in the other's frame: the pair's watch counts the frames in a
//      row it stayed within translation / rotation_deg of what it was `frames` seen frames before (a
//      sliding window, so that a grip held for seconds, over which the two estimates drift apart by
//      more than the tolerance, still counts) and notes whether the other moved min_motion or turned
//      min_turn_deg since the watch began, and whether the object itself did (a hand creeping past a
//      still object, slower than the tolerance per window, keeps the window but never moved it, and
//      would carry the object off with it); beyond the tolerance, or no longer
//      touching, the watch starts over. Watches of hidden objects wait (neither counted nor reset)
//      until they are seen again;
//   2. a hidden object is carried by the seen neighbour whose watch ran at least `frames` frames with
//      both motions (the longest such watch; ties: the lower id);
//   3. its pose is that neighbour's pose composed with their relative pose of the object's last seen
//      frame.
// A hand may cover a box before it grips it (the box hidden from the frame the hand comes near, and
// lifted away some frames later): then no watch of step 1 saw them
// move together. With seen_through_share > 0, steps 4-6 carry such an object too:
//   4. for every hidden object and seen neighbour that touch at this frame's poses (the hidden one's
//      is where it is held), a hidden watch keeps the object's pose in the neighbour's frame at the
//      grip: the touching frame in which the neighbour moved least since the frame before (its
//      translation over min_motion or its turn over min_turn_deg, the larger; ties: the later
//      frame), where a hand that reached for the box stops before it lifts it; until it carries, it
//      lasts until the object is seen again, touching or not (a box lifted away no longer touches
//      the pose where it is held);
//   5. a hidden object that step 2 does not carry, and of whose model the caller's test finds at
//      least seen_through_share seen through where it is held (the view shows what lies behind it:
//      it is not there any more), is carried by the neighbour of a hidden watch that moved
//      min_motion or turned min_turn_deg since the grip (the one touching it longest; ties: the
//      lower id), when at most carried_seen_through_share is seen through where that neighbour would
//      have carried it (hidden behind it, or there to see: a neighbour that only brushed a box whose
//      held pose had drifted off it would carry it into free space), from then until it is seen
//      again;
//   6. it is reported as gripped away by that neighbour, at the pose where it is held, and the caller
//      retires it: its pose is not known (carried with the gripper's estimated turn, a lifted box came
//      out 24-25 deg and 21 cm off; docs/departures.md, "Hidden objects carried").
// Deterministic, no draws. Non-copyable: it owns the watches.

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "mfot/types.hpp"

namespace mfot {

// Member defaults: off (the thesis); the merger and mfot-inprocess fill every field from
// configs/default.yaml (merger.carry).
struct CarryOptions {
  int frames = 0;                            // [0, 10000]; 0 = off
  float translation = 0.03f;                 // metres (0, 0.5]: a hand's estimate wobbles by a centimetre or two
  float rotation_deg = 15.f;                 // (0, 90]
  float min_motion = 0.03f;                  // metres (0, 1]
  float min_turn_deg = 10.f;                 // (0, 180]
  float contact_distance = 0.02f;            // the caller's touch test: model points this close, metres (0, 0.1]
  float seen_through_share = 0.f;            // [0, 1] where it is held; 0 = steps 4-6 off
  float carried_seen_through_share = 0.05f;  // [0, 1] where the neighbour would carry it
  void validate() const;                     // throws std::invalid_argument naming the field
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
    Pose pose;                  // where the carrier's motion put it; gripped away: where it is held
    bool gripped_away = false;  // by steps 5-6 (gripped while hidden): the caller retires it
  };
  using TouchTest = std::function<bool(std::int32_t, std::int32_t)>;
  // The share of an object's model seen through at a pose in this frame's view (OcclusionTest).
  using SeenThroughTest = std::function<float(std::int32_t, const Pose&)>;

  explicit CarryMonitor(const CarryOptions& options = {});
  CarryMonitor(const CarryMonitor&) = delete;
  CarryMonitor& operator=(const CarryMonitor&) = delete;

  const CarryOptions& options() const { return options_; }

  // objects: every object with an estimate this frame, ids unique. touch(a, b): whether the two
  // objects' models touch at their poses; asked once per pair of seen objects (and, with
  // options().seen_through_share > 0, of a hidden and a seen one). seen_through(id, pose): asked only
  // with options().seen_through_share > 0, of a hidden object that step 2 does not carry but a hidden
  // watch's neighbour could, at its pose and at where that neighbour would carry it; required then.
  // Returns the carried hidden objects (ascending id); nothing while options().frames is 0.
  const std::vector<Carried>& update(std::span<const Object> objects, const TouchTest& touch,
                                     const SeenThroughTest& seen_through = {});
  // The object is gone (retired, joined): its watches go too.
  void forget(std::int32_t id);

 private:
  struct Watch {
    // The object's pose in the neighbour's frame over the last `frames` seen frames, oldest first.
    std::deque<Eigen::Isometry3f> recent;
    Pose neighbour_at_start;
    Pose object_at_start;
    Eigen::Isometry3f last_seen = Eigen::Isometry3f::Identity();  // the latest seen relative pose
    int frames = 0;
    bool neighbour_moved = false;  // since the watch began ...
    bool object_moved = false;     // ... and the object too
  };
  // A hidden object's pose in a seen neighbour's frame at the grip (steps 4-6).
  struct HiddenWatch {
    Eigen::Isometry3f relative = Eigen::Isometry3f::Identity();
    Pose neighbour_at_grip;
    Pose neighbour_before;  // the neighbour's pose the last touching frame
    float grip_step = 0.f;  // the neighbour's step at the grip (units of min_motion / min_turn_deg)
    int frames = 0;         // frames touching
    bool carrying = false;
  };
  void observe(const Object& object, const Object& neighbour);
  void observe_hidden(const Object& object, const Object& neighbour);
  // Step 2: the carrier among objects of the hidden object (nullptr: none) and the relative pose it carries.
  const Object* watched_carrier(const Object& object, std::span<const Object> objects,
                                Eigen::Isometry3f& relative) const;
  // Step 5's candidate neighbour (nullptr: none) and its hidden watch.
  const Object* gripping_carrier(const Object& object, std::span<const Object> objects, HiddenWatch** watch);

  CarryOptions options_;
  std::map<std::pair<std::int32_t, std::int32_t>, Watch> watches_;               // (object, neighbour)
  std::map<std::pair<std::int32_t, std::int32_t>, HiddenWatch> hidden_watches_;  // (hidden object, neighbour)
  std::vector<Carried> carried_;
};

}  // namespace mfot
