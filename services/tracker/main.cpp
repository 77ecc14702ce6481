// mfot-tracker: one tracker worker. It idles until the merger assigns it an object on MFOT_MODEL_<id>,
// then runs that object's particle filter (thesis 2.2.2, 3.3) on every scene and publishes the
// estimate; it heartbeats so the merger can hand its object to another worker if this one dies or
// stalls. The protocol is TrackerWorker (services/common); this main wires it to LCM. The
// likelihood backend (JCSD on CUDA or CPU, or the point-to-point baseline) is chosen at run time;
// each worker owns its CUDA stream.

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <string>

#include "mfot/service/config.hpp"
#include "mfot/service/group_security.hpp"
#include "mfot/service/lcm_util.hpp"
#include "mfot/service/pipeline_config.hpp"
#include "mfot/service/service_main.hpp"
#include "mfot/service/status.hpp"
#include "mfot/service/tracker_worker.hpp"

namespace mfot::service {
namespace {

// Publishes what the worker says; LCM's subscriptions call member functions, which forward to it.
class LcmTrackerLink : public TrackerSink {
 public:
  LcmTrackerLink(lcm::LCM& lcm, StatusReporter& status) : lcm_(lcm), status_(status) {}
  void publish_estimate(const tracker_estimate_t& estimate) override {
    publish_message(lcm_, channel::kEstimate, estimate);
    status_.frame_done(estimate.compute_ms);
  }
  void publish_heartbeat(const heartbeat_t& heartbeat) override {
    publish_message(lcm_, channel::kHeartbeat, heartbeat);
  }
  void publish_model_report(const object_model_t& report) override {
    publish_message(lcm_, channel::kModelReport, report);
  }
  void note(const std::string& message) override { status_.set_message(message); }

  void subscribe(TrackerWorker& worker, std::int32_t worker_id) {
    worker_ = &worker;
    lcm_.subscribe(channel::model_channel(worker_id), &LcmTrackerLink::on_model, this);
    lcm_.subscribe(channel::kFrameDone, &LcmTrackerLink::on_frame_done, this);
    lcm_.subscribe(channel::kScene, &LcmTrackerLink::on_scene, this);
    lcm_.subscribe(channel::kStatus, &LcmTrackerLink::on_status, this);
    lcm_.subscribe(channel::kModelRequest, &LcmTrackerLink::on_model_request, this);
  }

 private:
  void on_model(const lcm::ReceiveBuffer* rbuf, const std::string& chan) { worker_->on_model(rbuf, chan); }
  void on_frame_done(const lcm::ReceiveBuffer* rbuf, const std::string& chan) { worker_->on_frame_done(rbuf, chan); }
  void on_scene(const lcm::ReceiveBuffer* rbuf, const std::string& chan) { worker_->on_scene(rbuf, chan); }
  void on_status(const lcm::ReceiveBuffer* rbuf, const std::string& chan) { worker_->on_status(rbuf, chan); }
  void on_model_request(const lcm::ReceiveBuffer* rbuf, const std::string& chan) {
    worker_->on_model_request(rbuf, chan);
  }

  lcm::LCM& lcm_;
  StatusReporter& status_;
  TrackerWorker* worker_ = nullptr;
};

int run_tracker(lcm::LCM& lcm, const TrackerConfig& config, int worker_id) {
  StatusReporter status(lcm, "tracker", worker_id, "");
  LcmTrackerLink link(lcm, status);
  TrackerWorker worker(config, {worker_id, process_instance(), host_name()}, link, status.malformed(),
                       [] { return std::chrono::steady_clock::now(); });
  const LikelihoodChoice& choice = worker.tracker().likelihood();
  status.set_backend(choice.backend);
  spdlog::info("likelihood backend {}{}", choice.backend, choice.note.empty() ? "" : " (" + choice.note + ")");
  link.subscribe(worker, worker_id);
  while (!stop_requested()) {
    if (!handle_for(lcm, 5)) {
      if (stop_requested()) break;  // the signal interrupted the wait
      spdlog::error("LCM receive failed; stopping");
      break;
    }
    // Drain what is queued, then track every scene whose model is here, in order.
    while (lcm.handleTimeout(0) > 0) {
    }
    worker.step();
    status.set_queue_depth(static_cast<int>(worker.queued_scenes()));
    status.tick();
  }
  return 0;
}

}  // namespace
}  // namespace mfot::service

int main(int argc, char** argv) {
  using namespace mfot::service;
  CLI::App app{"mfot-tracker: one particle-filter tracker worker"};
  std::string config_path;  // empty: the built-in defaults (configs/default.yaml)
  std::string lcm_url_arg;
  int worker_id = 0;
  app.add_option("--config", config_path, "YAML config (section `tracker`)");
  app.add_option("--lcm-url", lcm_url_arg, "LCM provider URL (default: $MFOT_LCM_URL, $LCM_DEFAULT_URL or udpm ttl=0)");
  app.add_option("--worker-id", worker_id, "this worker's id, unique in the group")
      ->required()
      ->check(CLI::Range(0, kMaxWorkerId));
  CLI11_PARSE(app, argc, argv);
  setup_logging("tracker", worker_id);
  install_signal_handlers();
  return run_service_main([&] {
    const YAML::Node root = load_config_file(config_path);
    const TrackerConfig config = load_tracker_config(root);
    install_group_security(root);
    lcm::LCM lcm(lcm_url(lcm_url_arg));
    if (!lcm.good()) {
      spdlog::error("cannot open LCM at {}", lcm_url(lcm_url_arg));
      return 1;
    }
    return run_tracker(lcm, config, worker_id);
  });
}
