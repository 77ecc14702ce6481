#pragma once
// Offline evaluation of a recorded run against simulator ground truth (thesis chapter 4):
// segmentation accuracy (4.3), relative pose error per object, tracks lost and the fitting
// distance (4.1, 4.2) the run recorded. The metrics themselves are mfot/metrics.hpp; this layer
// reads the recordings, pairs frames and objects, and collects the per-frame and per-object
// numbers.
//
// Inputs (frame numbers are the frame sequence numbers; images are <dir>/<frame %06d>.png):
//   run/poses.csv        frame,utime,object_id,x,y,z,qx,qy,qz,qw,confidence,stale  (object -> camera, m)
//   run/labels/          16-bit predicted label images, 0 = no object, 65535 = measured but not a
//                        scene point (service::kNotScenePoint: table, cropped, filtered)
//   run/fitting.csv      optional: frame,object_id,fitting_distance_m
//   run/timing.csv       optional: any numeric columns, summarised per column
//   gt/poses.csv         frame,utime,object_id,is_hand,x,y,z,qx,qy,qz,qw[,axis_x,axis_y,axis_z]
//   gt/labels/           16-bit ground-truth label images, 0 = table / background
//   gt/depth/ or run/depth/  optional 16-bit depth images (0 = no measurement), see below
//
// Steps of evaluate_run:
//  1. For every frame with both label images: the points are the pixels labelled non-zero in the
//     prediction OR the ground truth, restricted to pixels with a depth measurement when depth
//     images exist. Pixels where both say background are left out (they would inflate the
//     accuracy with the table), and so are pixels the sensor did not measure (no tracker can
//     label them). Without depth images every pixel labelled in either image counts. The
//     accuracy (thesis 4.3: "correctly associated points / all points" of the preprocessed
//     scene) counts the scene points only; the pixel accuracy also counts the measured pixels
//     preprocessing removed (as unlabelled), so what preprocessing loses stays visible.
//  2. SegmentationAccuracy maps predicted ids one-to-one to ground-truth ids by their overlap
//     over the whole sequence and gives the accuracy per frame and overall.
//  3. Per ground-truth object: its mapped predicted id's poses (stale rows included: they are
//     what a controller received) are paired with the ground truth frame by frame; the relative
//     pose error compares the motion since the first common frame and is summarised over the
//     frames after it.
//  4. The ground-truth objects are the ids with points in the evaluated frames (hands included,
//     counted apart). One is lost when no predicted id maps to it, or when its prediction's last
//     non-stale frame comes before the last evaluated frame the object has points in.
//  5. fitting.csv is averaged over objects per frame and over frames.

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "mfot/evaluate/csv_table.hpp"
#include "mfot/metrics.hpp"
#include "mfot/types.hpp"

namespace mfot::evaluate {

struct PredictedPoseRow {
  std::int64_t frame = 0;
  std::int64_t utime = 0;
  std::int32_t id = 0;
  Pose pose;  // object -> camera
  double confidence = 0.0;
  bool stale = false;
};

struct GroundTruthPoseRow {
  std::int64_t frame = 0;
  std::int64_t utime = 0;
  std::int32_t id = 0;
  bool is_hand = false;
  Pose pose;                                                // object -> camera
  Eigen::Vector3f symmetry_axis = Eigen::Vector3f::Zero();  // object frame; zero: none (optional columns)
};

struct TimingColumn {
  std::string name;
  std::size_t count = 0;
  double mean = 0.0, median = 0.0, p95 = 0.0, max = 0.0;
};

// Readers; all throw EvaluationError naming the file (and line).
std::vector<PredictedPoseRow> read_predicted_poses(const std::filesystem::path& csv);
std::vector<GroundTruthPoseRow> read_groundtruth_poses(const std::filesystem::path& csv);
// frame -> mean fitting distance (metres) over the objects listed for that frame.
std::map<std::int64_t, double> read_fitting_means(const std::filesystem::path& csv);
// Every numeric column except frame and utime.
std::vector<TimingColumn> read_timing(const std::filesystem::path& csv);
// Frames with a <frame %06d>.png in `dir`, sorted; throws when `dir` is not a directory.
std::vector<std::int64_t> label_frames(const std::filesystem::path& dir);
std::filesystem::path frame_image(const std::filesystem::path& dir, std::int64_t frame);

struct GroundTruth {
  std::filesystem::path directory;
  std::vector<GroundTruthPoseRow> poses;
  std::vector<std::int64_t> label_frames;
};
GroundTruth load_groundtruth(const std::filesystem::path& directory);

struct EvaluationOptions {
  double translation_threshold_mm = 10.0;  // (0, 1000]: "share of frames over" threshold
  double rotation_threshold_deg = 5.0;     // (0, 180]
  void validate() const;                   // throws std::invalid_argument naming the field
};

struct FrameResult {
  std::int64_t frame = 0;
  bool segmented = false;  // both label images exist
  std::size_t points = 0;  // evaluated points (step 1)
  double accuracy = 0.0;   // with the sequence-wide mapping; meaningful when segmented
  bool has_fitting = false;
  double fitting_mean_m = 0.0;
  int predicted_objects = 0;  // rows in poses.csv for this frame
};

struct ObjectResult {
  std::int32_t groundtruth_id = 0;
  bool is_hand = false;
  std::int32_t predicted_id = 0;                                         // 0: no predicted id maps to this object
  std::int64_t groundtruth_first_frame = 0, groundtruth_last_frame = 0;  // evaluated frames with its points
  std::int64_t predicted_first_frame = -1, predicted_last_frame = -1;    // last non-stale; -1: none
  bool lost = false;
  bool symmetric = false;            // the ground truth gives a symmetry axis (see PoseError)
  std::size_t stale_frames = 0;      // stale rows among the compared frames
  std::vector<std::int64_t> frames;  // compared frames, the first is t0
  std::vector<PoseError> errors;     // per compared frame (0 at t0)
  PoseErrorSummary summary;          // over the frames after t0
};

struct RunResult {
  std::string name;
  std::filesystem::path directory;
  std::vector<FrameResult> frames;  // every frame with labels, poses or fitting, sorted
  std::size_t segmented_frames = 0;
  std::size_t groundtruth_frames_without_prediction = 0;  // gt label frames the run has no labels for
  std::size_t points = 0;                                 // scene points evaluated over all frames
  double accuracy = 1.0;                                  // over scene points (thesis 4.3)
  std::size_t pixels = 0;                                 // measured pixels evaluated over all frames
  double pixel_accuracy = 1.0;                            // over all measured pixels, its own one-to-one mapping
  std::map<std::int32_t, std::int32_t> mapping;           // predicted id -> gt id (SegmentationAccuracy::kUnmatched)
  std::vector<SegmentationAccuracy::Overlap> overlaps;    // scene points per (predicted, gt) pair over all frames
  std::string depth_mask;                                 // directory of the depth images used, or "none"
  std::vector<ObjectResult> objects;                      // one per ground-truth id with points (step 4)
  std::size_t tracks_lost = 0;                            // lost objects that are not hands
  std::size_t hands_lost = 0;
  bool has_fitting = false;
  double fitting_mean_m = 0.0;  // mean over frames of the per-frame mean
  std::vector<TimingColumn> timing;
};

RunResult evaluate_run(const std::string& name, const std::filesystem::path& run_directory,
                       const GroundTruth& groundtruth, const EvaluationOptions& options);

}  // namespace mfot::evaluate
