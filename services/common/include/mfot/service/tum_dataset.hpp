#pragma once
// TUM RGB-D benchmark folders (https://cvg.cit.tum.de/data/datasets/rgbd-dataset/file_formats):
// rgb.txt and depth.txt list "<timestamp seconds> <relative png path>" ('#' starts a comment);
// colour is 8-bit RGB PNG, depth 16-bit PNG in units of 1/depth_scale metres (5000 per metre).
// Intrinsics are not part of the format: this project's writer adds intrinsics.txt
// ("fx fy cx cy"), which the reader uses when present.
//
// Ground truth of rendered scenes lives next to it in groundtruth/: poses.csv with one line per
// object and frame ("frame,utime,object_id,is_hand,x,y,z,qx,qy,qz,qw,axis_x,axis_y,axis_z", object ->
// camera, metres; the axis columns, an object's symmetry axis in its own frame or 0 0 0, are optional)
// and labels/<frame %06d>.png (16-bit object id per pixel, 0 = background).
//
// Writers are crash-safe per frame: images are written under temporary names and renamed, then
// the list lines are appended, so an interrupted run never leaves a listed but half-written frame.

#include <array>
#include <cstdint>
#include <cstdio>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "mfot/service/frame_codec.hpp"
#include "mfot/service/image_io.hpp"
#include "mfot/types.hpp"

namespace mfot::service {

struct DatasetError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The TUM "ROS default" intrinsics, used when a folder has no intrinsics.txt.
inline constexpr float kTumDefaultFx = 525.0f, kTumDefaultFy = 525.0f, kTumDefaultCx = 319.5f, kTumDefaultCy = 239.5f;

struct TumReaderOptions {
  std::string folder;
  double depth_scale = 5000.0;          // depth PNG units per metre, > 0
  double max_time_difference_s = 0.02;  // rgb/depth association tolerance, > 0
  // For a folder without intrinsics.txt (which wins when present): fx, fy, cx, cy; unset: the TUM
  // defaults.
  std::optional<std::array<float, 4>> intrinsics;

  void validate() const;  // std::invalid_argument naming the field
};

// One associated rgb/depth pair.
struct TumEntry {
  double rgb_time_s = 0.0;
  double depth_time_s = 0.0;
  std::string rgb_path;  // absolute or relative to the working directory
  std::string depth_path;
};

class TumDatasetReader {
 public:
  // Reads and associates the lists; throws DatasetError when the folder or a list file is
  // missing, or when no rgb/depth pair can be associated. Garbage lines are skipped with a
  // warning naming file:line.
  explicit TumDatasetReader(TumReaderOptions options);

  std::size_t size() const { return entries_.size(); }
  const TumEntry& entry(std::size_t index) const { return entries_.at(index); }
  const std::vector<TumEntry>& entries() const { return entries_; }
  const std::string& folder() const { return options_.folder; }

  // Loads pair `index`. A missing or corrupt image, or depth whose size differs from colour,
  // returns nullopt with a warning naming the file.
  std::optional<Frame> read(std::size_t index);

  // Every warning so far (also logged).
  const std::vector<std::string>& warnings() const { return warnings_; }

 private:
  void warn(std::string message);

  TumReaderOptions options_;
  std::array<float, 4> intrinsics_{};
  std::vector<TumEntry> entries_;
  std::vector<std::string> warnings_;
};

// Pairs each rgb time with the nearest depth time within `max_difference` (each depth used at
// most once, closest pairs first, as the TUM associate.py tool does). Returns (rgb index, depth
// index) pairs sorted by rgb time; inputs need not be sorted.
std::vector<std::pair<std::size_t, std::size_t>> associate_by_time(const std::vector<double>& rgb_times,
                                                                   const std::vector<double>& depth_times,
                                                                   double max_difference);

// ---- ground truth ------------------------------------------------------------------------------

struct GroundTruthObject {
  int id = 0;                                               // >= 1
  bool is_hand = false;                                     // the hand/gripper that moves objects (scored separately)
  Pose pose;                                                // object -> camera, metres
  Eigen::Vector3f symmetry_axis = Eigen::Vector3f::Zero();  // object frame, unit; zero = none
};

struct GroundTruthFrame {
  std::int64_t frame = 0;  // index in the sequence
  std::int64_t utime = 0;  // capture time, microseconds
  std::vector<GroundTruthObject> objects;
  Image16 labels;  // per-pixel object id, 0 = background; may be empty (no labels)
};

// Writes poses.csv and labels/ into `folder` (created if needed; an existing poses.csv is an
// error so runs never mix).
class GroundTruthWriter {
 public:
  explicit GroundTruthWriter(std::string folder);
  GroundTruthWriter(const GroundTruthWriter&) = delete;
  GroundTruthWriter& operator=(const GroundTruthWriter&) = delete;
  ~GroundTruthWriter();

  void write(const GroundTruthFrame& truth);
  // Writes scene.yaml (the scene's summary, SceneSummary::yaml()) into the folder; empty: nothing.
  void write_scene(const std::string& yaml);

 private:
  std::string folder_;
  std::FILE* poses_ = nullptr;
};

// Reads poses.csv (garbage lines skipped with a warning naming file:line) and labels on demand.
class GroundTruthReader {
 public:
  explicit GroundTruthReader(std::string folder);

  // Frame index -> objects, sorted by frame.
  const std::map<std::int64_t, GroundTruthFrame>& frames() const { return frames_; }
  // Labels of `frame`; nullopt with a warning when the file is missing or unreadable.
  std::optional<Image16> labels(std::int64_t frame);
  const std::vector<std::string>& warnings() const { return warnings_; }

 private:
  std::string folder_;
  std::map<std::int64_t, GroundTruthFrame> frames_;
  std::vector<std::string> warnings_;
};

// Label file name of a frame: "%06d.png".
std::string label_file_name(std::int64_t frame);

// ---- writer ------------------------------------------------------------------------------------

struct TumWriterOptions {
  std::string folder;             // created; must not already contain rgb.txt
  double depth_scale = 5000.0;    // depth PNG units per metre, > 0
  bool write_groundtruth = true;  // create groundtruth/ (poses.csv, labels/)

  void validate() const;
};

class TumDatasetWriter {
 public:
  explicit TumDatasetWriter(TumWriterOptions options);
  TumDatasetWriter(const TumDatasetWriter&) = delete;
  TumDatasetWriter& operator=(const TumDatasetWriter&) = delete;
  ~TumDatasetWriter();

  // Writes one frame (and its ground truth when given and enabled). Frames must come in
  // increasing capture time; intrinsics.txt is written from the first frame.
  void write(const Frame& frame, const GroundTruthFrame* truth = nullptr);
  // groundtruth/scene.yaml (GroundTruthWriter::write_scene) when ground truth is enabled.
  void write_scene(const std::string& yaml) {
    if (truth_) truth_->write_scene(yaml);
  }

  std::size_t frames_written() const { return frames_written_; }
  // Depth pixels that did not fit a 16-bit PNG at this depth scale and were written as 0.
  std::size_t depth_pixels_clipped() const { return depth_pixels_clipped_; }

 private:
  TumWriterOptions options_;
  std::FILE* rgb_list_ = nullptr;
  std::FILE* depth_list_ = nullptr;
  std::optional<GroundTruthWriter> truth_;
  std::size_t frames_written_ = 0;
  std::size_t depth_pixels_clipped_ = 0;
  std::int64_t last_utime_ = 0;
};

}  // namespace mfot::service
