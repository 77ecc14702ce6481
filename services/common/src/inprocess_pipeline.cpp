#include "mfot/service/inprocess_pipeline.hpp"

#include <spdlog/spdlog.h>

#include <chrono>

#include "mfot/service/lcm_util.hpp"

namespace mfot::service {

namespace {
using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }
}  // namespace

InprocessPipeline::InprocessPipeline(const InprocessOptions& options)
    : options_(options),
      preprocessor_(options.preprocess),
      manager_(options.manager, make_object_discoveries(options.manager.discovery, options.merger_threads)),
      claimed_margin_(options.tracker.step.claimed_margin()) {}

const InprocessFrame& InprocessPipeline::process(const Frame& frame, std::int64_t seq, const std::string& source_name) {
  const auto t0 = Clock::now();
  frame_.message = encode_frame(frame, options_.encoding, seq, source_name, now_utime());
  const Frame decoded = decode_frame(frame_.message);  // what the services see after the wire
  frame_.times.codec_ms = ms_since(t0);

  const auto t_preprocess = Clock::now();
  Scene& scene = frame_.scene;
  scene_from_cloud(preprocessor_.process(image_view(decoded), seq), decoded, seq, scene);
  frame_.times.preprocess_ms = ms_since(t_preprocess);

  const auto t_track = Clock::now();
  std::map<std::int32_t, ObjectEstimate> estimates;
  for (auto& [id, tracker] : trackers_) {
    // What the merger sends with each model (MergerCore::send_model).
    if (claimed_margin_ > 0.f) manager_.claimed_points(id, claimed_margin_, claimed_);
    tracker->set_claimed_points(claimed_);
    tracker->set_view(scene.view);
    const TrackingStepResult step = tracker->track(scene.cloud);
    estimates[id] = {step.estimate, step.confidence, step.held};
    spdlog::debug(
        "frame {} object {} ({} model points): {} share {:.2f}, {} points scored, {} occluders and {} claimed "
        "left out, {} claims near{}, fit {:.3f}, seen through {:.3f}, t [{:.3f} {:.3f} {:.3f}]",
        seq, id, tracker->model().cloud.size(), step.held ? "held" : "stepped", step.occluded_share,
        step.hypothesis_points, step.occluders_removed, step.claimed_removed, claimed_.size(),
        std::string(step.isolated ? ", isolated" : "") + (step.companion ? ", companion's motion" : "") +
            (step.icp_refined ? ", ICP-refined" : "") + (step.last_pose_kept ? ", last pose kept" : "") +
            (step.companion_pose_kept ? ", companion's pose kept" : "") +
            (step.companion_turn_kept ? ", companion's turn kept" : ""),
        step.fit, step.seen_through_share, step.estimate.translation.x(), step.estimate.translation.y(),
        step.estimate.translation.z());
  }
  frame_.times.track_ms = ms_since(t_track);

  const auto t_merge = Clock::now();
  manager_.set_view(scene.view);
  const ObjectManagerFrame& result = manager_.process(scene.cloud, scene.cluster, scene.standing_clusters, estimates);
  for (const std::int32_t id : result.retired) trackers_.erase(id);
  const ObjectTrackerOptions tracker_options{options_.tracker.likelihood, options_.tracker.filter,
                                             options_.tracker.step};
  for (const auto& [id, object] : manager_.objects()) {
    auto& tracker = trackers_[id];
    if (!tracker) tracker = std::make_unique<ObjectTracker>(tracker_options);
    tracker->set_model(id, object.version, object.model, object.pose, object.carried_by != 0);
    tracker->set_companion_motion(object.companion != 0 ? std::optional<PoseVector>(object.companion_motion)
                                                        : std::nullopt);
  }
  frame_.times.merge_ms = ms_since(t_merge);
  return frame_;
}

}  // namespace mfot::service
