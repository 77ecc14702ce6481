#pragma once
// What MergerCore said, recorded for tests, and a clock the test moves by hand.

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "mfot/service/merger_core.hpp"

namespace mfot::service::testing {

struct SentModel {
  std::int32_t object_id;
  std::int32_t worker_id;
  std::int64_t worker_instance;
  std::int64_t frame_seq;
  Pose pose;
  std::size_t model_points;
  std::vector<Eigen::Vector3f> claimed;  // the other objects' points sent with it
  std::int32_t recipient;                // the worker whose channel carries it
  std::int32_t version;
  std::int32_t held_version;  // the version it may go as an edit of, -1 = whole
};

struct PublishedFrame {
  std::int64_t frame_seq;
  std::vector<std::int32_t> labels;
  std::vector<std::int32_t> created;
  std::vector<std::int32_t> retired;
  std::map<std::int32_t, Pose> poses;
  std::map<std::int32_t, bool> stale;
};

class RecordingSink : public MergerSink {
 public:
  void send_model(const ManagedObject& object, std::int32_t worker_id, std::int64_t worker_instance,
                  std::int64_t frame_seq, std::span<const Eigen::Vector3f> claimed, std::int32_t recipient,
                  const HeldModel* held) override {
    models.push_back({object.id, worker_id, worker_instance, frame_seq, object.pose, object.model.cloud.size(),
                      std::vector<Eigen::Vector3f>(claimed.begin(), claimed.end()), recipient, object.version,
                      held != nullptr ? held->version : -1});
  }
  void send_retirement(std::int32_t object_id, std::int64_t frame_seq, std::int32_t recipient) override {
    retirements.emplace_back(object_id, frame_seq);
    retirement_recipients.push_back(recipient);
  }
  void request_model(std::int32_t object_id, std::int32_t worker_id, std::int64_t worker_instance) override {
    requests.push_back({object_id, worker_id, worker_instance});
  }
  void send_frame_done(frame_done_t& message) override { frame_dones.push_back(message); }
  void resend_scene(std::span<const std::uint8_t> message) override {
    resent_scenes.emplace_back(message.begin(), message.end());
  }
  void publish_frame(const FinishedFrame& frame) override {
    PublishedFrame p{frame.scene.frame_seq, frame.result.labels, frame.result.created, frame.result.retired, {}, {}};
    for (const auto& [id, object] : frame.objects) {
      p.poses[id] = object.pose;
      p.stale[id] = object.stale;
    }
    frames.push_back(std::move(p));
  }
  void note(const std::string& message) override { notes.push_back(message); }

  std::vector<SentModel> models;
  std::vector<std::pair<std::int32_t, std::int64_t>> retirements;
  std::vector<ObjectResumer::Request> requests;
  std::vector<std::int32_t> retirement_recipients;
  std::vector<frame_done_t> frame_dones;
  std::vector<std::vector<std::uint8_t>> resent_scenes;
  std::vector<PublishedFrame> frames;
  std::vector<std::string> notes;
};

struct ManualClock {
  std::chrono::steady_clock::time_point now{std::chrono::seconds(1000)};
  void advance(std::chrono::milliseconds ms) { now += ms; }
  auto function() {
    return [this] { return now; };
  }
};

}  // namespace mfot::service::testing
