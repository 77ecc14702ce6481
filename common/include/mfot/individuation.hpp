#pragma once
// Object individuation helpers, thesis 3.1 after [KLK14]: Euclidean clustering of the scene,
// detection of clusters no tracked object explains (new objects) and of objects that lost
// their support in the segmentation (objects to retire).

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <span>
#include <utility>
#include <vector>

#include "mfot/spatial_hash.hpp"

namespace mfot {

// ---- Euclidean clustering ----------------------------------------------------------------------

struct EuclideanClusterOptions {
  float tolerance = 0.010f;           // metres, (0, 1]: points closer than this are connected
  std::size_t min_cluster_size = 30;  // >= 1: smaller clusters are dropped (no size is too large)
  void validate() const;
};

// Clusters in compressed form: cluster k holds point_indices[offsets[k], offsets[k + 1]),
// in increasing index order; clusters are ordered by their lowest point index.
struct ClusterSet {
  std::vector<int> point_indices;
  std::vector<int> offsets{0};
  std::vector<std::int32_t> cluster_of_point;  // per input point: cluster index, -1 = none (dropped)

  std::size_t size() const { return offsets.size() - 1; }
  std::span<const int> cluster(std::size_t k) const {
    return {point_indices.data() + offsets[k], static_cast<std::size_t>(offsets[k + 1] - offsets[k])};
  }
};

// Connected components of the graph linking points closer than tolerance (the region growing
// of [RC11]). Steps: index the points (spatial hash, cell = tolerance); flood-fill from the
// lowest unvisited point with radius searches; keep components whose size is within bounds.
class EuclideanClusterer {
 public:
  explicit EuclideanClusterer(const EuclideanClusterOptions& options = {});
  EuclideanClusterer(const EuclideanClusterer&) = delete;
  EuclideanClusterer& operator=(const EuclideanClusterer&) = delete;

  const EuclideanClusterOptions& options() const { return options_; }
  void cluster(std::span<const Eigen::Vector3f> points, ClusterSet& out);

 private:
  EuclideanClusterOptions options_;
  SpatialHash hash_;
  std::vector<int> frontier_;
  std::vector<int> neighbours_;
  std::vector<int> component_;
  std::vector<std::uint8_t> visited_;
};

// Share of each cluster's points with segmentation label 0 (no tracked object), one per cluster.
void unassigned_shares(const ClusterSet& clusters, std::span<const std::int32_t> labels, std::vector<float>& out);

// ---- new objects -----------------------------------------------------------------------------

struct NewObjectOptions {
  float min_unassigned_share = 0.5f;  // (0, 1]: a cluster is unexplained above this share of label-0 points
  int confirm_frames = 3;             // >= 1: consecutive frames a candidate must persist
  float match_distance = 0.02f;       // metres, (0, 1]: a point overlaps a candidate within this distance
  float min_overlap = 0.5f;           // (0, 1]: share of overlapping points to continue a candidate
  void validate() const;
};

// Tracks clusters that no tracked object explains over frames and reports those persisting for
// confirm_frames consecutive frames. Steps per frame:
//   1. unexplained clusters: share of unassigned points (label 0) > min_unassigned_share;
//   2. overlap of every unexplained cluster with every candidate of the previous frame: the
//      share of the cluster's points within match_distance of the candidate's previous points;
//   3. one-to-one matching, greedy by overlap (ties: lower candidate, then lower cluster), pairs
//      below min_overlap are not matched; a matched candidate continues with the cluster's
//      points, an unmatched cluster starts a candidate, an unmatched candidate is dropped;
//   4. candidates that reach confirm_frames are reported (their cluster index) and forgotten.
class NewObjectDetector {
 public:
  struct Candidate {
    std::uint64_t key = 0;                // stable over the candidate's life, increasing with creation
    int frames = 0;                       // consecutive frames seen
    int cluster = -1;                     // cluster index in the latest frame
    std::vector<Eigen::Vector3f> points;  // its points in the latest frame, camera frame
  };

  explicit NewObjectDetector(const NewObjectOptions& options = {});
  NewObjectDetector(const NewObjectDetector&) = delete;
  NewObjectDetector& operator=(const NewObjectDetector&) = delete;

  const NewObjectOptions& options() const { return options_; }

  // points: the scene clustered into clusters; labels: the segmentation of the same points; only clusters
  // [0, candidate_clusters) may become objects (those standing on the table, SceneCloud::standing_clusters).
  // confirmed receives (cleared first) the indices of clusters that become new objects, ascending.
  void update(std::span<const Eigen::Vector3f> points, const ClusterSet& clusters, std::span<const std::int32_t> labels,
              std::vector<int>& confirmed, std::size_t candidate_clusters = std::numeric_limits<std::size_t>::max());

  const std::vector<Candidate>& candidates() const { return candidates_; }
  void reset();

 private:
  NewObjectOptions options_;
  std::vector<Candidate> candidates_;
  std::uint64_t next_key_ = 0;
  SpatialHash hash_;
  std::vector<Eigen::Vector3f> candidate_points_;  // all candidates' points, for one index
  std::vector<int> candidate_owner_;
  std::vector<float> shares_;
  std::vector<int> neighbours_;
  std::vector<int> hits_;  // per candidate, for one cluster
};

// ---- lost objects ----------------------------------------------------------------------------

struct SupportLossOptions {
  std::size_t min_points = 20;  // an object with fewer segmented points lacks support
  int max_frames = 5;           // >= 1: consecutive frames without support before retiring
  void validate() const;
};

// Counts, per object, consecutive frames with fewer than min_points segmented points and
// reports objects that reach max_frames. A hidden object's frames (occluded: it cannot have
// support) leave its count as it was. Objects absent from an update are forgotten.
class SupportMonitor {
 public:
  explicit SupportMonitor(const SupportLossOptions& options = {});

  const SupportLossOptions& options() const { return options_; }

  // ids and counts as in SegmentationResult; hidden: per id, non-zero when the object is hidden
  // this frame (empty: none is). retired receives (cleared first) the ids to retire, in input
  // order; they are forgotten here.
  void update(std::span<const std::int32_t> ids, std::span<const std::size_t> counts,
              std::span<const std::uint8_t> hidden, std::vector<std::int32_t>& retired);

  // Consecutive frames without support of id so far (0 when unknown).
  int frames_without_support(std::int32_t id) const;
  // id's count goes (0 from now on, until it lacks support again).
  void forget(std::int32_t id) {
    std::erase_if(misses_, [id](const auto& entry) { return entry.first == id; });
  }

 private:
  SupportLossOptions options_;
  std::vector<std::pair<std::int32_t, int>> misses_;  // id -> consecutive frames, in last input order
  std::vector<std::pair<std::int32_t, int>> next_misses_;
};

}  // namespace mfot
