#pragma once
// A companion's motion for a gripped object's filter (a departure from the thesis, docs/experiment-log.md "Where mfot
// departs from the thesis"): a box that a hand grips and turns turns with the hand, but its own dX
// (2.13) lags the turn, since the filter's weighted mean and its refinement move only part of the way
// each frame while the hand covers much of it. The object's filter predicts
// a share of its particles by the motion that moving rigidly with a touching object would give it
// (ParticleFilterOptions::companion_fraction); the likelihood keeps them only where the object did move
// so. Steps of ObjectManager's companion choice, per object and frame:
//   1. candidates are the other objects seen this frame (not held, not stale) that moved at least
//      min_motion or turned min_turn_deg in their last step;
//   2. each candidate's last step dX, repeated (the thesis's prediction 2.15), is carried over to the
//      object as if the two were one rigid body (companion_increment);
//   3. of the candidates whose models touch the object's (contact_distance), the one whose increment
//      moves the object furthest (translation plus turn times the model's radius) is its companion.

#include "mfot/types.hpp"

namespace mfot {

// Member defaults: off (the thesis); the merger and mfot-inprocess fill every field from
// configs/default.yaml (merger.companion).
struct CompanionOptions {
  float contact_distance = 0.f;  // models closer than this touch, metres [0, 0.1]; 0 = off
  float min_motion = 0.002f;     // metres (0, 1]
  float min_turn_deg = 0.5f;     // (0, 180]
  void validate() const;         // throws std::invalid_argument naming the field
};

// The increment (pose_difference convention: translation added, rotation composed on the left about
// the object's origin) that the companion's next step, predicted as its last one repeated (its
// velocity, pose_difference of its last two poses, applied to `companion_pose`), gives an object at
// `pose` moving rigidly with it. An object's own pose and velocity give its velocity back.
PoseVector companion_increment(const Pose& pose, const Pose& companion_pose, const PoseVector& companion_velocity);

// Whether a last step moved min_motion or turned min_turn_deg.
bool companion_moved(const PoseVector& velocity, const CompanionOptions& options);

// How far an increment moves an object whose model reaches `radius` metres from its origin: its
// translation plus its turn (radians) times the radius.
float increment_reach(const PoseVector& increment, float radius);

}  // namespace mfot
