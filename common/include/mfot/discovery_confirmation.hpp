#pragma once
// The bookkeeping of the discovery's confirmation (step 7 of ObjectManager; DiscoveryOptions::confirm_frames, a
// departure from the thesis, which finds objects once: docs/departures.md). Over their first confirm_frames frames,
// the objects born from one cluster (siblings of one birth) are discovered again together; the ObjectManager does the
// discovery and changes the objects, this class decides. Per frame and birth:
//   1. match(): each of the discovery's parts is taken by the object it overlaps most (largest overlaps first, one
//      part per object and object per part); they disagree when a part is left untaken (the birth found two objects as
//      one) or a piece of at least min_part_points of one object lies in another's part (the birth frame cut wrongly);
//   2. watch_siblings(): each pair of the birth's objects counts the frames its two objects lay mostly in one part,
//      and in different parts;
//   3. vote(): once the parts disagreed in confirm_votes frames, this frame's parts become the objects (the caller
//      adopts them) and the count starts over;
//   4. unparted_siblings(): when an object leaves the confirmation, each of its pairs never seen apart, together in
//      at least confirm_frames - confirm_votes + 1 frames, is one object: the smaller joins the larger.

#include <cstdint>
#include <functional>
#include <map>
#include <span>
#include <utility>
#include <vector>

#include "mfot/object_discovery.hpp"

namespace mfot {

// How the discovery's parts of a birth's objects meet those objects (this frame's labels).
struct PartMatch {
  std::vector<std::map<std::int32_t, std::size_t>> labels_in_part;  // per part: label -> its points there
  std::vector<std::int32_t> member_of_part;                         // per part: the object that took it, 0 = none
  std::map<std::int32_t, std::size_t> part_of_member;               // object -> the part it took
  // A part no object took, or a piece of at least min_piece points of an object that took a part inside another's
  // part.
  bool disagrees(std::size_t min_piece) const;
};

class DiscoveryConfirmation {
 public:
  explicit DiscoveryConfirmation(const DiscoveryOptions& options);
  DiscoveryConfirmation(const DiscoveryConfirmation&) = delete;
  DiscoveryConfirmation& operator=(const DiscoveryConfirmation&) = delete;

  // Step 1. parts: scene indices; labels: per scene point, the object id (0 = none).
  static PartMatch match(const std::vector<std::vector<int>>& parts, std::span<const std::int32_t> labels);
  // Step 2. members: the birth's objects this frame (their segmented points), keyed by id.
  void watch_siblings(const std::map<std::int32_t, std::vector<int>>& members, const PartMatch& match);
  // Step 3: whether this frame's parts become the birth's objects.
  bool vote(std::uint64_t birth, bool disagrees);
  // Votes of births not in `births` are dropped (their objects left the confirmation).
  void keep_votes_of(const std::function<bool(std::uint64_t)>& births);
  // Step 4. leaving: objects that leave the confirmation this frame; model_size(id): its model's points. Returns
  // the joins (kept, joined) in order, each pair's ids as they are after the joins before it (a piece of three
  // joins what its sibling joined); the decided pairs are forgotten.
  std::vector<std::pair<std::int32_t, std::int32_t>> unparted_siblings(
      std::span<const std::int32_t> leaving, const std::function<std::size_t(std::int32_t)>& model_size);
  void forget(std::int32_t id);  // its pairs
  std::size_t watched_pairs() const { return siblings_.size(); }

 private:
  struct SiblingWatch {
    int together = 0;  // frames in which most of both objects' points lay in one part
    int apart = 0;     // ... in different parts
  };
  DiscoveryOptions options_;
  std::map<std::uint64_t, int> votes_;                                      // per birth: frames the parts disagreed
  std::map<std::pair<std::int32_t, std::int32_t>, SiblingWatch> siblings_;  // lower id first
};

}  // namespace mfot
