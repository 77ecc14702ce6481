#pragma once
// A run folder's per-frame results, written the same way by the merger and mfot-inprocess:
// poses.csv first (flushed before the caller publishes the poses, so every published frame's
// poses are on disk even if the process is killed right after), then fitting.csv (thesis eq.
// 4.1-4.2) and the dense label image. With `background` those two are computed and written on a
// lower-priority output thread from copies of what they need, at most a few frames behind (a
// process killed meanwhile leaves the last frames without them; label images appear whole or not
// at all), so they stay off the frame-to-pose path.

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>

#include "mfot/frame_t.hpp"
#include "mfot/metrics.hpp"
#include "mfot/object_manager.hpp"
#include "mfot/service/background_queue.hpp"
#include "mfot/service/convert.hpp"
#include "mfot/service/lcm_util.hpp"
#include "mfot/service/run_writer.hpp"
#include "mfot/thread_pool.hpp"

namespace mfot::service {

struct RunOutputsOptions {
  bool write_labels = true;      // labels/<frame>.png (merger.write_labels)
  bool fitting_distance = true;  // fitting.csv (merger.fitting_distance)
  bool background = false;       // fitting and labels on the output thread
  // With background: threads that compute the label image and each object's fitting distance side by
  // side, [0, 64]; 0 = a quarter of the cores, 2 to 4 (1 below 4 cores). The files are the same for any count.
  int threads = 0;
};

class RunOutputs {
 public:
  // Creates `dir` (see RunWriter); `append` continues its CSV files (a restarted merger).
  // Undecodable frames given for label images are counted in `malformed`.
  RunOutputs(const std::string& dir, bool append, RunOutputsOptions options, MalformedCounter& malformed);
  RunOutputs(const RunOutputs&) = delete;
  RunOutputs& operator=(const RunOutputs&) = delete;
  ~RunOutputs();

  // poses.csv rows of every object for this frame, flushed.
  void write_poses(std::int64_t frame_seq, std::int64_t capture_utime,
                   const std::map<std::int32_t, ManagedObject>& objects);
  // fitting.csv rows and the label image of this frame; `frame` is the frame the scene came from
  // (only its depth is decoded), nullopt when it is not at hand (no label image then).
  void write_frame(const Scene& scene, std::span<const std::int32_t> labels,
                   const std::map<std::int32_t, ManagedObject>& objects, std::optional<frame_t> frame);
  // Waits for the output thread and flushes every file; rethrows an output job's failure.
  void finish();

 private:
  struct FittingInput {
    std::int32_t id;
    std::vector<Eigen::Vector3f> model;
    Pose pose;
  };
  void write_outputs(std::int64_t seq, const std::vector<Eigen::Vector3f>& points,
                     const std::vector<std::int32_t>& labels, const std::vector<FittingInput>& fitting,
                     const std::optional<frame_t>& frame, const VoxelGrid& voxel_grid);

  RunOutputsOptions options_;
  MalformedCounter& malformed_;
  RunWriter writer_;
  FittingDistanceEvaluator fitting_;          // output thread only
  std::vector<double> fitting_means_;         // output thread only: this frame's, per FittingInput
  std::unique_ptr<ThreadPool> output_split_;  // output thread only: fitting beside the label image
  // Declared after what its jobs use, so it is destroyed (finishing them) first.
  std::unique_ptr<BackgroundQueue> queue_;
};

}  // namespace mfot::service
