#pragma once
// Evaluation metrics of thesis chapter 4: fitting distance (4.1, 4.2), point-level
// segmentation accuracy (4.3, PMOTA of [KLK14]) and, where ground-truth poses exist (the
// simulator), the relative pose error of every object.

#include <cstdint>
#include <map>
#include <span>
#include <utility>
#include <vector>

#include "mfot/occlusion.hpp"
#include "mfot/spatial_hash.hpp"
#include "mfot/types.hpp"

namespace mfot {

// ---- fitting distance ------------------------------------------------------------------------

struct FittingDistanceOptions {
  bool occlusion_test = true;  // false: plain average nearest-neighbour distance
  // Half-angle of the viewing cone around a model point's camera ray, as a tangent (distance
  // in the normalised image plane x/z, y/z), (0, 0.1]. 0.006 is ~3.4 px at fx = 570, a little
  // more than the angular spacing of 5 mm voxels at 1 m, so a surface in front always has a
  // point inside the cone.
  float occlusion_window = 0.006f;
  // A scene point occludes only when it is at least this much closer to the camera (metres,
  // [0, 1]): the points of the object's own visible surface never count.
  float depth_margin = 0.010f;
  void validate() const;
};

struct FittingDistance {
  double mean = 0.0;             // metres: (4.2), occluded model points count as 0
  std::size_t model_points = 0;  // n
  std::size_t occluded = 0;      // model points with d_i = 0 by the occlusion test
};

// Thesis 4.1, 4.2: d = 1/n sum_i d_i, d_i = |m_i - z_nn(i)| for a visible model point m_i (in
// the estimated pose), 0 for an occluded one. Occlusion test (ray casting from the camera at
// the origin): m_i is occluded when a scene point lies inside the cone of half-angle
// occlusion_window around the ray through m_i and is at least depth_margin closer to the camera
// (depth along z; OcclusionTest). Model points at z <= 0 are behind the camera and count as
// occluded. Steps: set_scene indexes the scene twice (3-D positions; OcclusionTest's normalised
// image coordinates with their depth); evaluate moves the model into the camera frame and does one
// nearest-neighbour search and one cone search per model point.
class FittingDistanceEvaluator {
 public:
  explicit FittingDistanceEvaluator(const FittingDistanceOptions& options = {});
  FittingDistanceEvaluator(const FittingDistanceEvaluator&) = delete;
  FittingDistanceEvaluator& operator=(const FittingDistanceEvaluator&) = delete;

  const FittingDistanceOptions& options() const { return options_; }

  void set_scene(std::span<const Eigen::Vector3f> scene_points);  // camera frame
  // model_points: object frame; pose: object -> camera. Without scene points every visible
  // model point has no neighbour: the result's mean is then infinite. Several objects may be
  // evaluated side by side on one scene (reads only).
  FittingDistance evaluate(std::span<const Eigen::Vector3f> model_points, const Pose& pose) const;

 private:
  FittingDistanceOptions options_;
  SpatialHash scene_hash_;
  OcclusionTest occlusion_;
  std::vector<Eigen::Vector3f> scene_;
};

// ---- segmentation accuracy -------------------------------------------------------------------

// Thesis 4.3: accuracy = correctly labelled points / all points, over a sequence. Predicted
// ids are arbitrary, so they are first mapped one-to-one to ground-truth ids: every pair
// (predicted != 0, ground truth != 0) is weighted by its overlap (points over the whole
// sequence) and pairs are taken greedily by decreasing overlap (ties: lower predicted id, then
// lower ground-truth id) while both are free. 0 (background) maps to 0; a predicted id left
// without partner maps to kUnmatched and all its points count as wrong.
class SegmentationAccuracy {
 public:
  static constexpr std::int32_t kUnmatched = -1;
  // Points one predicted id gave one ground-truth id over the sequence, and in how many frames:
  // where the wrong points went (a seam between touching objects persists in most frames, a
  // passing mix-up in a few).
  struct Overlap {
    std::int32_t predicted = 0;
    std::int32_t ground_truth = 0;
    std::uint64_t points = 0;
    std::size_t frames = 0;
  };

  // One frame's labels, point by point (same size).
  void add_frame(std::span<const std::int32_t> predicted, std::span<const std::int32_t> ground_truth);

  std::size_t frames() const { return frame_pairs_.size(); }
  std::size_t points() const { return total_points_; }
  double accuracy() const;                               // 1 for an empty sequence
  std::vector<double> frame_accuracies() const;          // with the sequence-wide mapping
  std::map<std::int32_t, std::int32_t> mapping() const;  // predicted id -> ground-truth id
  std::vector<Overlap> overlaps() const;                 // every pair seen, by (predicted, ground truth)

 private:
  using Pair = std::pair<std::int32_t, std::int32_t>;  // (predicted, ground truth)
  std::map<Pair, std::uint64_t> overlap_;
  std::vector<std::vector<std::pair<Pair, std::uint64_t>>> frame_pairs_;
  std::size_t total_points_ = 0;
  std::vector<std::size_t> frame_points_;
};

// ---- relative pose error ---------------------------------------------------------------------

struct PoseError {
  double translation_mm = 0.0;  // displacement error at the object's centre (see below)
  double rotation_deg = 0.0;
  double translation_at_camera_mm = 0.0;  // |t_pred - t_gt| of the motions (the literal reading)
  // For a shape symmetric about an axis (a can), rotation about that axis is unobservable from
  // shape: the error of the observable part is the angle between where the two motions carry the
  // axis. Without an axis it equals rotation_deg.
  double observable_rotation_deg = 0.0;
};

// Errors of one object's trajectory: frame t compares the predicted motion X_t X_t0^-1 with the
// ground-truth motion G_t G_t0^-1, t0 = index 0 (the first tracked frame). The motions are
// invariant to the choice of object frame (X = G O for a constant O), so a model-free tracker's
// centroid frame compares directly with the simulator's. Rotation error: angle of R_gt^T R_pred.
// Translation error: the distance between where the two motions carry the object's centre c
// (the ground-truth origin at t0): |M_pred c - M_gt c|. The literal |t_pred - t_gt| measures the
// displacement of the camera origin instead, which turns every 0.1 degree of rotation noise
// into ~2 mm at the 1.1 m of a table-top scene; it is kept as translation_at_camera_mm. Both are
// invariant to the choice of object frame. The spans must have one size. symmetry_axis: the
// object's axis of symmetry in the ground-truth object frame (unit), or zero for none.
std::vector<PoseError> relative_pose_errors(std::span<const Pose> predicted, std::span<const Pose> ground_truth,
                                            const Eigen::Vector3f& symmetry_axis = Eigen::Vector3f::Zero());

struct PoseErrorSummaryOptions {
  double translation_threshold_mm = 10.0;
  double rotation_threshold_deg = 5.0;
};

struct PoseErrorSummary {
  std::size_t count = 0;
  double translation_mean_mm = 0.0, translation_median_mm = 0.0, translation_max_mm = 0.0;
  double rotation_mean_deg = 0.0, rotation_median_deg = 0.0, rotation_max_deg = 0.0;
  double observable_rotation_median_deg = 0.0, observable_rotation_max_deg = 0.0;  // see PoseError
  double share_translation_over = 0.0;  // share of frames with translation error > threshold
  double share_rotation_over = 0.0;     // share of frames with rotation error > threshold
  double share_either_over = 0.0;       // share of frames over either threshold
};

// Summary over the given errors (pass the frames after t0 to leave out its zero error);
// median of an even count is the mean of the two middle values.
PoseErrorSummary summarize(std::span<const PoseError> errors, const PoseErrorSummaryOptions& options = {});

// ---- object segmentation of a scene (object discovery) ----------------------------------------

// How found objects compare with ground-truth segments, per labelled point (after Richtsfeld et
// al.'s OSD and Stein et al.'s LCCP evaluation): a segment is found when one object overlaps it with
// IoU >= found_iou; WOv is the segment-size-weighted best IoU.
struct SegmentMatchOptions {
  double found_iou = 0.5;   // (0, 1]
  double part_share = 0.2;  // an object holding at least this share of a segment holds a part of it, (0, 0.5]
  void validate() const;    // throws std::invalid_argument naming the field
};

struct SegmentMatch {
  std::size_t segments = 0;       // ground-truth segments (labels != 0)
  std::size_t objects = 0;        // predicted objects (labels != 0)
  std::size_t found = 0;          // segments with an object of IoU >= found_iou
  double weighted_overlap = 0.0;  // WOv: sum over segments of size x best IoU / sum of sizes; 1 with no segment
  std::size_t merged = 0;         // segments whose largest object also holds most of another segment
  std::size_t split = 0;          // segments at least two objects each hold part_share of
  std::size_t spurious = 0;       // objects with most of their points on background (truth 0)
};

// truth / predicted: one label per point (0 = background / no object), same length (else
// std::invalid_argument).
SegmentMatch match_segments(std::span<const std::int32_t> truth, std::span<const std::int32_t> predicted,
                            const SegmentMatchOptions& options = {});

}  // namespace mfot
