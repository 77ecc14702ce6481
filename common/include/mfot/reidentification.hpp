#pragma once
// Re-identification's memory (a departure from the thesis, docs/departures.md "Re-identification"): the objects the
// ObjectManager retired lately, each with its last model, pose, parts and the colours it showed last and when it was
// created, so that a new object whose colours match one of them takes its id back (ObjectManager step 6). A live object
// not seen in the frame (held by its tracker, or lacking support but not retired yet) is such a candidate too
// (UnseenObject): a newcomer matching it is that object found elsewhere, so it keeps one id instead of a new one born
// before the old one retires. Colours are compared as 8-bin SMR histograms (smr_feature.hpp) by the Bhattacharyya
// coefficient. Deterministic, no draws.

#include <array>
#include <cstdint>
#include <map>
#include <span>
#include <vector>

#include "mfot/likelihood.hpp"
#include "mfot/smr_feature.hpp"
#include "mfot/types.hpp"

namespace mfot {

// A model's colour distribution: its points' SMR features summed and normalised (all zero for no points).
using ColorHistogram = std::array<float, kSmrBins>;
ColorHistogram color_histogram(const ObjectModel& model);
// The Bhattacharyya coefficient of two histograms, in [0, 1].
float color_similarity(const ColorHistogram& a, const ColorHistogram& b);

// A model's radius: its points' largest distance from their centroid (metres, 0 for none). It does not depend on the
// model's frame, so a newcomer's (axis-aligned with the camera) and a known object's (its own frame) compare.
float model_radius(const ObjectModel& model);

// A live object not seen in the frame (ObjectManager step 6): the newcomer's candidate as a retired object is.
struct UnseenObject {
  std::int32_t id = 0;
  ColorHistogram histogram{};   // of its model
  ColorHistogram first_seen{};  // of its model when created
  float radius = 0.f;           // model_radius of its model
};

struct RetiredObject {
  std::int64_t retired_frame = 0;
  std::int32_t version = 0;
  ColorHistogram histogram{};   // of its last model
  ColorHistogram first_seen{};  // of its model when created: what reaching in again shows first
  ObjectModel model;            // its last model and pose, for the registration
  Pose pose;
  std::vector<std::uint32_t> part_ends;  // its model's parts (ManagedObject::part_ends)
};

class RetiredObjects {
 public:
  // similarity: the least Bhattacharyya coefficient of a match, (0, 1] (ObjectManagerOptions::reidentify_similarity).
  explicit RetiredObjects(float similarity) : similarity_(similarity) {}

  // Remembers object id (an earlier memory of it is replaced).
  void remember(std::int32_t id, RetiredObject object) { retired_[id] = std::move(object); }
  // Forgets those retired `frames` or more frames before `frame`.
  void expire(std::int64_t frame, int frames);
  // The remembered id, retired in frame retired_by or before, whose last or first colours the histogram matches
  // best, at least at the similarity; ties keep the lowest id; 0 = none.
  std::int32_t match(const ColorHistogram& histogram, std::int64_t retired_by) const;
  // The unseen object whose last or first colours the histogram matches best, at least at the similarity, among
  // those whose radius is at least radius / max_radius_ratio (a view of an object lies within its diameter: a
  // newcomer more than twice as large is another object, or more than one); ties keep the lowest id; 0 = none.
  // max_radius_ratio > 0.
  std::int32_t match_unseen(std::span<const UnseenObject> unseen, const ColorHistogram& histogram, float radius,
                            float max_radius_ratio) const;
  const RetiredObject& at(std::int32_t id) const { return retired_.at(id); }
  void forget(std::int32_t id) { retired_.erase(id); }  // its id was taken back (or is live again)
  std::size_t size() const { return retired_.size(); }

 private:
  float similarity_;
  std::map<std::int32_t, RetiredObject> retired_;
};

}  // namespace mfot
