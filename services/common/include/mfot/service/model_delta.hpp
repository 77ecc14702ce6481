#pragma once
// A model version as an edit of the version before, for the merger-to-tracker wire (object_model_t's
// is_delta): the points of the base kept, in order, and the new points placed among them. The merger's model
// changes by growth (points appended, the whole thinned evenly), by re-fitted parts (a part's points moved)
// and by the forgetting update (points dropped, new ones appended), so most of a new version is points of the
// version before, unchanged to the bit. Lossless: applying the edit to the base gives the model bit for bit.
// Steps of diff_models:
//   1. index the base's points by their bits (position and colour);
//   2. walk the model's points in order: a point equal to the next base point, or to a later one that the
//      model's next point follows too, is kept (the base points skipped on the way are left out); any other
//      is new (a point moved back, or one repeated further on, does not leave out what lies between);
//   3. the base's points after the last one taken are left out.
// apply_model_delta checks every count against the base and the new points (a forged or corrupt edit is
// refused with the problem named, nothing assembled) and assembles the model.

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "mfot/types.hpp"

namespace mfot::service {

// The version of an object's model its owner was sent last (and holds, unless that message was lost).
struct HeldModel {
  std::int32_t version;
  const ColoredCloud& cloud;  // object frame
};

struct ModelDelta {
  std::vector<std::int32_t> base_runs;    // over the base's points: alternately kept and left out, kept first
  std::vector<std::int32_t> order_runs;   // over the model's points: alternately kept and new, kept first
  std::vector<std::uint32_t> new_points;  // the model's new points (indices into it), ascending
};

class ModelDiffer {
 public:
  // The edit that makes `model` of `base` (both in the object frame); valid until the next call.
  const ModelDelta& diff(const ColoredCloud& base, const ColoredCloud& model);

 private:
  struct Key {
    std::uint32_t x, y, z, rgb;
    friend bool operator==(const Key&, const Key&) = default;
  };
  struct KeyHash {
    std::size_t operator()(const Key& k) const;
  };
  static Key key_of(const Eigen::Vector3f& p, Rgb8 c);
  std::unordered_map<Key, std::vector<std::uint32_t>, KeyHash> index_;  // base point indices, ascending
  ModelDelta delta_;
};

// The model that base_runs / order_runs (as in ModelDelta) and the new points make of `base`, into `out`;
// an error names the count that disagrees (a negative run, runs summing to other than the base's points,
// kept runs of the two disagreeing, new runs to other than the new points), with `out` cleared.
std::optional<std::string> apply_model_delta(const ColoredCloud& base, std::span<const std::int32_t> base_runs,
                                             std::span<const std::int32_t> order_runs, const ColoredCloud& new_points,
                                             ColoredCloud& out);

}  // namespace mfot::service
