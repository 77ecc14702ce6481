#pragma once
// Joining the parts of one rigid object and splitting an object whose parts moved apart (step 7 of
// ObjectManager; a departure from the thesis, whose objects are found once: docs/departures.md). The discovery
// cuts a cluster into locally convex parts, so one object with a concave or textured face may be born as two, and
// a hand that lets go of a box was one cluster with it. Motion tells them apart:
// RigidPartJoin, per frame, for each pair of objects born from one cluster (siblings) and seen this frame:
//   1. their relative pose (the second in the first's frame) is compared with the pair's watch: within
//      join_translation and join_rotation_deg the watch counts one more frame, else it starts over here;
//   2. after join_frames frames, if the first moved join_min_motion or turned join_min_turn_deg since the watch
//      began and their models touch (join_contact_distance), the second joins the first.
// OverlapJoin, per frame, for each pair of objects seen this frame (an estimate, not held or carried):
//   1. the share of the smaller model within join_contact_distance of the other's, at their poses (the caller's);
//   2. overlap_share or more for overlap_frames frames in a row: the higher id joins the lower.
// PartSplit, per object and frame:
//   1. its segmented points by Euclidean cluster: the parts holding at least min_object_points and split_min_share
//      of them; two or more, the largest two split_min_gap apart and at most split_max_occluded of its model hidden,
//      make a frame in parts;
//   2. each part is followed from last frame's (its centroid, moved with the object or left where it was, within
//      split_min_gap), remembering where and at which object pose it was first seen apart;
//   3. after split_frames frames in parts, every part but the largest that departed split_min_departure from
//      where the object's motion since then would have put it leaves; the object keeps the rest.

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <map>
#include <span>
#include <utility>
#include <vector>

#include "mfot/spatial_hash.hpp"
#include "mfot/types.hpp"

namespace mfot {

// Member defaults: both off (the thesis has neither); the shipped values are pipeline constants.
struct JoinSplitOptions {
  // RigidPartJoin: join_frames frames (0 = off, [0, 10000]) within join_translation (metres, (0, 0.1]) and
  // join_rotation_deg ((0, 45]) while the first moves join_min_motion (metres, (0, 1]) or turns join_min_turn_deg
  // ((0, 180]), models within join_contact_distance (metres, (0, 0.1]).
  int join_frames = 0;
  float join_translation = 0.005f;
  float join_rotation_deg = 3.f;
  float join_min_motion = 0.03f;
  float join_min_turn_deg = 20.f;
  float join_contact_distance = 0.01f;
  // PartSplit: split_frames frames in parts (0 = off, [0, 10000]); a part holds at least split_min_share of the
  // object's segmented points ((0, 0.5]); the largest two lie split_min_gap apart (metres, [0, 1]: a grazing view
  // that cuts an arm from its hand by a few centimetres is not two objects); at most split_max_occluded of the model
  // hidden ([0, 1]: a hand in front cuts the visible part in two); a part leaves once it departed
  // split_min_departure (metres, [0, 1]; 0 = any part leaves; above 0 it needs split_min_gap > 0, within which
  // parts are followed) from where the object's own motion would have put it: a hand seen in two clusters (its
  // front and its arm) moves as one, a box it lets go of stays behind.
  int split_frames = 0;
  float split_min_share = 0.2f;
  float split_min_gap = 0.03f;
  float split_max_occluded = 0.1f;
  float split_min_departure = 0.f;
  // OverlapJoin: two seen objects of which at least overlap_share ((0, 1]) of the smaller model lies within
  // join_contact_distance of the other's model, at their poses, for overlap_frames frames in a row (0 = off,
  // [0, 10000]), are one object (two rigid bodies cannot share their space): the higher id joins the lower (an id
  // re-identified keeps its number, so the lower is the one consumers knew first).
  int overlap_frames = 0;
  float overlap_share = 0.5f;
  void validate() const;  // throws std::invalid_argument naming the field
};

// One object of a frame for RigidPartJoin.
struct JoinCandidate {
  std::int32_t id = 0;
  std::uint64_t birth = 0;  // the discovery split it was born from: only siblings join
  Pose pose;                // object -> camera
  bool stale = false;       // no estimate this frame: not compared
};

class RigidPartJoin {
 public:
  explicit RigidPartJoin(const JoinSplitOptions& options);
  RigidPartJoin(const RigidPartJoin&) = delete;
  RigidPartJoin& operator=(const RigidPartJoin&) = delete;

  // objects: this frame's, ascending ids. touch(a, b): whether a's and b's models touch within
  // join_contact_distance at this frame's poses (asked only for pairs due to join). Returns (kept, joined) pairs, in
  // order of (kept, joined) ids; an id may occur in several (the caller skips pairs of which one is gone).
  std::vector<std::pair<std::int32_t, std::int32_t>> update(
      std::span<const JoinCandidate> objects, const std::function<bool(std::int32_t, std::int32_t)>& touch);
  void forget(std::int32_t id);  // its pairs' watches
  std::size_t watched_pairs() const { return pairs_.size(); }

 private:
  struct PairWatch {
    Eigen::Isometry3f relative = Eigen::Isometry3f::Identity();  // the second in the first's frame
    Pose start;                                                  // the first's pose when the watch began
    int frames = 0;
  };
  JoinSplitOptions options_;
  std::map<std::pair<std::int32_t, std::int32_t>, PairWatch> pairs_;
};

// One object of a frame for OverlapJoin.
struct OverlapCandidate {
  std::int32_t id = 0;
  bool seen = false;  // an estimate this frame, not held or carried: its pose is where it is
};

// Two objects that occupy one space (OverlapJoin in the header comment): an object born again from the points of one
// still tracked elsewhere (its estimate slipped while it was hidden and came back), or a part of an object that the
// discovery found apart and whose model covers the same surface.
class OverlapJoin {
 public:
  explicit OverlapJoin(const JoinSplitOptions& options);
  OverlapJoin(const OverlapJoin&) = delete;
  OverlapJoin& operator=(const OverlapJoin&) = delete;

  // objects: this frame's, ascending ids. overlap(a, b): the share of the smaller of a's and b's models within
  // join_contact_distance of the other's, at this frame's poses. Returns (kept, joined) pairs in order of the pairs'
  // ids; an id may occur in several (the caller skips pairs of which one is gone).
  std::vector<std::pair<std::int32_t, std::int32_t>> update(
      std::span<const OverlapCandidate> objects, const std::function<float(std::int32_t, std::int32_t)>& overlap);
  void forget(std::int32_t id);  // its pairs' counts
  std::size_t watched_pairs() const { return frames_.size(); }

 private:
  JoinSplitOptions options_;
  std::map<std::pair<std::int32_t, std::int32_t>, int> frames_;  // frames in a row the pair overlapped
};

// One part of an object seen in parts, followed from frame to frame: its centroid (camera frame) last frame, and
// where and at which object pose it was first seen apart.
struct SplitPart {
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
  Eigen::Vector3f first_centroid = Eigen::Vector3f::Zero();
  Pose first_pose;
};

// PartSplit's state of one object (kept in its record, so that it goes with the object).
struct SplitWatch {
  int streak = 0;                // frames in a row it lay in parts apart
  Pose pose;                     // its pose the last frame it lay in parts ...
  std::vector<SplitPart> parts;  // ... and those parts (empty: not in parts)
};

class PartSplit {
 public:
  // min_object_points: the least points of a part (and of an object), >= 1.
  PartSplit(const JoinSplitOptions& options, std::size_t min_object_points);
  PartSplit(const PartSplit&) = delete;
  PartSplit& operator=(const PartSplit&) = delete;

  // One object's frame. clusters: its segmented points (scene indices) by Euclidean cluster, ascending clusters;
  // scene: the scene's positions; occluded_share(): the share of its model hidden at its pose (asked only when
  // needed). Returns true when it splits: leaving, the parts that leave (each a new object), and own (ascending),
  // the points it keeps; the watch then starts over.
  bool update(const Pose& pose, bool stale, const std::map<std::int32_t, std::vector<int>>& clusters,
              std::span<const Eigen::Vector3f> scene, const std::function<float()>& occluded_share, SplitWatch& watch,
              std::vector<int>& own, std::vector<std::vector<int>>& leaving);

 private:
  // Step 2: this frame's parts (empty: not apart, and the watch's parts go), each followed from last frame's.
  std::vector<SplitPart> follow(const Pose& pose, SplitWatch& watch, std::span<const Eigen::Vector3f> scene,
                                std::span<const std::vector<int>* const> parts) const;

  JoinSplitOptions options_;
  std::size_t min_object_points_;
  SpatialHash gap_hash_{0.03f};
  std::vector<Eigen::Vector3f> first_;
};

}  // namespace mfot
