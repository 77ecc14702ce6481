#pragma once
// Labels propagated through a cluster (ObjectManager step 5; a departure from the thesis, docs/departures.md
// "Unexplained points next to objects"): after the nearest-model segmentation (3.22, 3.23) the points of a cluster
// that no object explains take the label of the nearest segmented point reachable through unexplained points in
// steps of at most `radius` (the rest of an arm entering the view, what tau missed of an object). Steps of
// propagate(), per cluster:
//   1. the cluster's points split into the labelled (the first wave) and the unexplained;
//   2. a cluster with no unexplained point, none labelled, or fewer labelled than min_seed_share of its points
//      keeps its labels (seeded too thinly it is no part of its labelled points' objects: a box a hand put down);
//   3. in waves: each unexplained point within radius of the last wave's points takes the label of the nearest of
//      them and joins the next wave, so labels spread along the cluster's surface, never across a wider gap.
// Deterministic: points and ties in index order; every point of a wave sees the same wave. Non-copyable: it keeps
// its buffers and spatial hash between calls.

#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <span>
#include <vector>

#include "mfot/spatial_hash.hpp"

namespace mfot {

class LabelPropagation {
 public:
  // radius: metres, [0, 0.1], 0 = off (nothing propagates); min_seed_share: [0, 1], 0 = any seeding. Throws
  // std::invalid_argument outside those ranges.
  LabelPropagation(float radius, float min_seed_share);
  LabelPropagation(const LabelPropagation&) = delete;
  LabelPropagation& operator=(const LabelPropagation&) = delete;

  // positions: the scene's points; labels: per scene point (0 = unexplained), changed in place; cluster_points:
  // one cluster's point indices. gained is cleared, then holds per label the points (scene indices, in wave order)
  // that took it.
  void propagate(std::span<const Eigen::Vector3f> positions, std::span<const int> cluster_points,
                 std::span<std::int32_t> labels, std::map<std::int32_t, std::vector<int>>& gained);

 private:
  float radius_;
  float min_seed_share_;
  SpatialHash wave_hash_;
  std::vector<int> free_, wave_, next_wave_;
  std::vector<std::int32_t> wave_labels_;
  std::vector<Eigen::Vector3f> wave_points_;
};

}  // namespace mfot
