#pragma once
// Writes a run's results next to its lcm log, in formats any tool can score:
//   poses.csv    frame,utime,object_id,x,y,z,qx,qy,qz,qw,confidence,stale   (metres, object->camera)
//   fitting.csv  frame,object_id,fitting_distance_m                          (thesis 4.1, 4.2)
//   labels/<frame %06d>.png  16-bit label image aligned with the depth image (0 = none)

#include <cstdint>
#include <fstream>
#include <span>
#include <string>

#include "mfot/frame_t.hpp"
#include "mfot/service/image_io.hpp"
#include "mfot/types.hpp"
#include "mfot/voxel_grid.hpp"

namespace mfot::service {

class RunWriter {
 public:
  // Creates dir (and dir/labels); throws OutputError naming the path on failure. With
  // `append` the CSV files of an earlier writer (a restarted merger) are continued.
  explicit RunWriter(const std::string& dir, bool append = false);
  RunWriter(const RunWriter&) = delete;
  RunWriter& operator=(const RunWriter&) = delete;

  const std::string& dir() const { return dir_; }
  void write_pose(std::int64_t frame, std::int64_t utime, std::int32_t object_id, const Pose& pose, float confidence,
                  bool stale);
  void write_fitting(std::int64_t frame, std::int32_t object_id, double fitting_distance_m);
  // Written to a temporary name and renamed, so a reader never sees half an image.
  void write_labels(std::int64_t frame, const Image16& labels);
  // The flushes throw OutputError (service_main.hpp) naming the file and the system's reason when
  // bytes could not be written (a full disk), as do write_labels and the constructor.
  void flush();
  // The poses (write_pose, flush_poses) and the per-frame outputs (write_fitting, write_labels,
  // flush_fitting) touch separate files: each group may be used from its own thread.
  void flush_poses();
  void flush_fitting();

 private:
  std::string dir_;
  std::ofstream poses_;
  std::ofstream fitting_;
};

// `run_dir`/labels/<frame %06d>.png (the folder must exist), written under a temporary name and
// renamed, so a reader never sees half an image; OutputError naming the path when it cannot be.
void write_label_image(const std::string& run_dir, std::int64_t frame, const Image16& labels);

// Label image value of a measured pixel that is not a scene point (table, cropped, filtered out),
// so an evaluation can score the scene points (thesis 4.3) apart from all measured pixels.
inline constexpr std::uint16_t kNotScenePoint = 65535;

// Dense label image: every pixel whose back-projected 3D point falls in a scene voxel carries
// that voxel's label (0 = no object); other measured pixels carry kNotScenePoint, unmeasured 0.
// Voxels are the cells of voxel_grid (the preprocess grid of that frame);
// scene point k (a voxel mean, so inside its voxel) carries labels[k].
Image16 dense_labels(int width, int height, float fx, float fy, float cx, float cy,
                     std::span<const std::uint16_t> depth_mm, const VoxelGrid& voxel_grid,
                     std::span<const Eigen::Vector3f> scene_points, std::span<const std::int32_t> labels);

// dense_labels of the frame a scene came from, its depth decoded (only: the colour is not needed). Throws
// FrameCodecError for a frame that does not decode.
Image16 frame_label_image(const frame_t& frame, const VoxelGrid& voxel_grid,
                          std::span<const Eigen::Vector3f> scene_points, std::span<const std::int32_t> labels);

}  // namespace mfot::service
