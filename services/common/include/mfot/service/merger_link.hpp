#pragma once
// The merger's side of LCM: publishes what MergerCore says (models, retirements, frame ends, re-sent
// scenes, segmentation and poses), writes the run folder's poses.csv and fitting.csv, and reports on
// MFOT_STATUS. The label images are drawn from the log after the run (log_label_images.hpp).

#include <memory>
#include <optional>
#include <string>

#include "mfot/service/merger_core.hpp"
#include "mfot/service/pipeline_config.hpp"
#include "mfot/service/pose_velocity.hpp"
#include "mfot/service/run_outputs.hpp"
#include "mfot/service/status.hpp"

namespace mfot::service {

// The core's options of the `merger` config section.
MergerCoreOptions merger_core_options(const MergerConfig& config);

class LcmMergerLink : public MergerSink {
 public:
  // `output_dir`: write poses.csv and fitting.csv there (`append`: continue them).
  LcmMergerLink(lcm::LCM& lcm, StatusReporter& status, const MergerConfig& config,
                const std::optional<std::string>& output_dir, bool append);

  // Models and retirements go out on the recipient's channel (channel::model_channel).
  void send_model(const ManagedObject& object, std::int32_t worker_id, std::int64_t worker_instance,
                  std::int64_t frame_seq, std::span<const Eigen::Vector3f> claimed, std::int32_t recipient,
                  const HeldModel* held) override;
  void send_retirement(std::int32_t object_id, std::int64_t frame_seq, std::int32_t recipient) override;
  void send_frame_done(frame_done_t& message) override;
  void request_model(std::int32_t object_id, std::int32_t worker_id, std::int64_t worker_instance) override;
  void resend_scene(std::span<const std::uint8_t> message) override;
  void publish_frame(const FinishedFrame& frame) override;
  void note(const std::string& message) override { status_.set_message(message); }

  // Waits for the output thread and flushes the files.
  void finish();

 private:
  lcm::LCM& lcm_;
  StatusReporter& status_;
  Pose world_from_camera_;
  PoseVelocityEstimator velocities_;  // MFOT_POSES velocities
  std::unique_ptr<RunOutputs> outputs_;
  ModelDiffer differ_;  // finds a new model version's edit
};

}  // namespace mfot::service
