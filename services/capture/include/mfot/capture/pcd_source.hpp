#pragma once
// A folder of organised PCD files (PCL's point cloud format: x y z with rgb or rgba, as PCL's PCD
// grabber and recorder write them, and as datasets such as mOSD ship), played in natural name order
// (frame2 before frame10) like a recording. Each file becomes the registered RGB-D frame the
// pipeline carries: depth from z (millimetres), colour from rgb(a), and the pinhole intrinsics
// fitted to the organised cloud (least squares of u = fx x/z + cx and v = fy y/z + cy over its
// measured points). Files carry no time: frames are frame_period_s apart. A `label` field becomes
// the frame's ground truth (a label image, no poses; mfot-evaluate scores segmentation against it).
// A file that cannot be
// used (unreadable, truncated, not organised, no colour, no measured point) is skipped with an error
// naming it, and counted; the source goes on.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "mfot/capture/frame_source.hpp"

namespace mfot::capture {

struct PcdImage;

class PcdFolderSource final : public FrameSource {
 public:
  // Throws CaptureError when the folder is missing or holds no .pcd file. Labels up to
  // background_label_max are background in the ground truth (mOSD: 1-9 are the table).
  PcdFolderSource(const std::string& folder, double frame_period_s, std::uint32_t background_label_max);

  std::optional<SourceFrame> next() override;
  std::string name() const override { return "pcd:" + folder_; }
  std::string kind() const override { return "pcd"; }
  bool rewind() override;

  const std::vector<std::filesystem::path>& files() const { return files_; }
  std::int64_t skipped_files() const { return skipped_; }

 private:
  std::string folder_;
  double frame_period_s_;
  std::uint32_t background_label_max_;
  std::vector<std::filesystem::path> files_;  // natural name order
  std::size_t next_file_ = 0;
  std::int64_t index_ = 0;
  std::int64_t skipped_ = 0;
};

// The frame of an organised cloud; throws CaptureError when it has no measured point to fit the
// intrinsics to.
service::Frame frame_from_organised_cloud(const PcdImage& image);

// The cloud's `label` field as ground truth for mfot-evaluate: a label image (labels up to
// background_label_max become 0, background), no poses.
service::GroundTruthFrame labels_as_truth(const PcdImage& image, std::int64_t index, std::int64_t utime,
                                          std::uint32_t background_label_max);

// Natural order: runs of digits compare as numbers ("f2" < "f10").
bool natural_less(const std::string& a, const std::string& b);

}  // namespace mfot::capture
