#include "mfot/service/run_outputs.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <thread>

#include "mfot/service/frame_codec.hpp"

namespace mfot::service {

namespace {
// Frames whose label image and fitting distances may wait for the output thread before the
// caller waits for it; it runs this much nicer than the caller's thread.
constexpr std::size_t kOutputBacklog = 8;
constexpr int kOutputNiceIncrement = 5;
}  // namespace

RunOutputs::RunOutputs(const std::string& dir, bool append, RunOutputsOptions options, MalformedCounter& malformed)
    : options_(options), malformed_(malformed), writer_(dir, append) {
  if (options_.threads < 0 || options_.threads > 64) {
    throw std::invalid_argument("RunOutputsOptions.threads must be in [0, 64], got " +
                                std::to_string(options_.threads));
  }
  if (options_.background) {
    queue_ = std::make_unique<BackgroundQueue>("run output writer", kOutputBacklog, kOutputNiceIncrement);
  }
}

RunOutputs::~RunOutputs() = default;

void RunOutputs::write_poses(std::int64_t frame_seq, std::int64_t capture_utime,
                             const std::map<std::int32_t, ManagedObject>& objects) {
  for (const auto& [id, object] : objects) {
    writer_.write_pose(frame_seq, capture_utime, id, object.pose, object.confidence, object.stale);
  }
  writer_.flush_poses();
}

void RunOutputs::write_frame(const Scene& scene, std::span<const std::int32_t> labels,
                             const std::map<std::int32_t, ManagedObject>& objects, std::optional<frame_t> frame) {
  std::vector<FittingInput> fitting;
  if (options_.fitting_distance && !scene.cloud.empty()) {
    for (const auto& [id, object] : objects) fitting.push_back({id, object.model.cloud.positions, object.pose});
  }
  if (!options_.write_labels) frame.reset();
  if (!queue_) {
    write_outputs(scene.frame_seq, scene.cloud.positions, {labels.begin(), labels.end()}, fitting, frame,
                  scene.voxel_grid);
    return;
  }
  queue_->push([this, seq = scene.frame_seq, points = scene.cloud.positions,
                labels = std::vector<std::int32_t>(labels.begin(), labels.end()), fitting = std::move(fitting),
                frame = std::move(frame),
                voxel_grid = scene.voxel_grid] { write_outputs(seq, points, labels, fitting, frame, voxel_grid); });
}

void RunOutputs::write_outputs(std::int64_t seq, const std::vector<Eigen::Vector3f>& points,
                               const std::vector<std::int32_t>& labels, const std::vector<FittingInput>& fitting,
                               const std::optional<frame_t>& frame, const VoxelGrid& voxel_grid) {
  // The label image and each object's fitting distance are independent: side by side they keep the
  // output thread ahead of the frame rate (with 12 objects the distances one after the other took
  // longer than a frame, so the backlog filled and held the merger up). Made here so that its threads
  // inherit the output thread's lower priority (RunOutputsOptions::threads). Below 4 cores there is no
  // core to spare (the 2-core dev machine's group is CPU-bound), nor in the caller's own thread.
  if (!output_split_) {
    const unsigned cores = std::thread::hardware_concurrency();
    const int automatic = cores >= 4 ? static_cast<int>(std::clamp(cores / 4, 2u, 4u)) : 1;
    output_split_ = std::make_unique<ThreadPool>(!queue_ ? 1 : options_.threads > 0 ? options_.threads : automatic);
  }
  if (!fitting.empty()) fitting_.set_scene(points);
  fitting_means_.assign(fitting.size(), 0.0);
  output_split_->run(1 + fitting.size(), [&](std::size_t task) {
    if (task > 0) {
      const FittingInput& object = fitting[task - 1];
      fitting_means_[task - 1] = fitting_.evaluate(object.model, object.pose).mean;
      return;
    }
    if (!frame) return;
    try {
      writer_.write_labels(seq, frame_label_image(*frame, voxel_grid, points, labels));
    } catch (const FrameCodecError& e) {
      malformed_.record(channel::kFrame, "undecodable frame", e.what());  // MalformedCounter locks
    }
  });
  for (std::size_t k = 0; k < fitting.size(); ++k) writer_.write_fitting(seq, fitting[k].id, fitting_means_[k]);
  writer_.flush_fitting();
}

void RunOutputs::finish() {
  if (queue_) queue_->finish();
  writer_.flush();
}

}  // namespace mfot::service
