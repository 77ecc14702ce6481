// mfot-merger: the authority on objects. Wires LCM to MergerCore (services/common): it waits for
// the assigned trackers' estimates of each scene (with a timeout), segments, updates models,
// creates and retires objects, assigns objects to tracker workers (and reassigns those of dead
// workers); LcmMergerLink publishes models, segmentation and the controller-facing poses and
// writes the run folder.

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <optional>
#include <string>

#include "mfot/service/config.hpp"
#include "mfot/service/group_security.hpp"
#include "mfot/service/lcm_util.hpp"
#include "mfot/service/merger_core.hpp"
#include "mfot/service/merger_link.hpp"
#include "mfot/service/pipeline_config.hpp"
#include "mfot/service/service_main.hpp"
#include "mfot/service/status.hpp"

namespace mfot::service {
namespace {

// LCM's subscriptions call member functions; these forward to the core.
struct CoreSubscriber {
  MergerCore& core;
  void on_scene(const lcm::ReceiveBuffer* rbuf, const std::string& chan) { core.on_scene(rbuf, chan); }
  void on_estimate(const lcm::ReceiveBuffer* rbuf, const std::string& chan) { core.on_estimate(rbuf, chan); }
  void on_heartbeat(const lcm::ReceiveBuffer* rbuf, const std::string& chan) { core.on_heartbeat(rbuf, chan); }
  void on_model_report(const lcm::ReceiveBuffer* rbuf, const std::string& chan) { core.on_model_report(rbuf, chan); }
};

int run_merger(lcm::LCM& lcm, const MergerConfig& config, const std::optional<std::string>& output_dir, bool append) {
  StatusReporter status(lcm, "merger", 0, "cpu");
  LcmMergerLink link(lcm, status, config, output_dir, append);
  MergerCore core(merger_core_options(config), link, status.malformed(),
                  [] { return std::chrono::steady_clock::now(); });
  CoreSubscriber subscriber{core};
  lcm.subscribe(channel::kScene, &CoreSubscriber::on_scene, &subscriber);
  lcm.subscribe(channel::kEstimate, &CoreSubscriber::on_estimate, &subscriber);
  lcm.subscribe(channel::kHeartbeat, &CoreSubscriber::on_heartbeat, &subscriber);
  lcm.subscribe(channel::kModelReport, &CoreSubscriber::on_model_report, &subscriber);
  spdlog::info("merger up (tau {} m, alpha {})", config.manager.segmentation.tau, config.manager.model_update.alpha);
  while (!stop_requested()) {
    if (!handle_for(lcm, 5)) {
      if (stop_requested()) break;  // the signal interrupted the wait
      spdlog::error("LCM receive failed; stopping");
      break;
    }
    core.step();
    status.set_queue_depth(static_cast<int>(core.open_frames()));
    status.tick();
  }
  link.finish();
  spdlog::info("stopped after {} frames; {} objects tracked", status.frames(), core.manager().objects().size());
  return 0;
}

}  // namespace
}  // namespace mfot::service

int main(int argc, char** argv) {
  using namespace mfot::service;
  CLI::App app{"mfot-merger: segmentation, model update and object management"};
  std::string config_path;  // empty: the built-in defaults (configs/default.yaml)
  std::string lcm_url_arg;
  std::string output_dir;
  bool append_output = false;
  app.add_option("--config", config_path, "YAML config (section `merger`)");
  app.add_option("--lcm-url", lcm_url_arg, "LCM provider URL (default: $MFOT_LCM_URL, $LCM_DEFAULT_URL or udpm ttl=0)");
  app.add_option("--output-dir", output_dir, "write poses.csv and fitting.csv here");
  app.add_flag("--append-output", append_output,
               "continue the CSV files already in --output-dir (a restarted merger) instead of starting them anew");
  CLI11_PARSE(app, argc, argv);
  setup_logging("merger", 0);
  install_signal_handlers();
  return run_service_main([&] {
    const YAML::Node root = load_config_file(config_path);
    const MergerConfig config = load_merger_config(root);
    install_group_security(root);
    lcm::LCM lcm(lcm_url(lcm_url_arg));
    if (!lcm.good()) {
      spdlog::error("cannot open LCM at {}", lcm_url(lcm_url_arg));
      return 1;
    }
    spdlog::info("LCM {}", lcm_url(lcm_url_arg));
    return run_merger(lcm, config, output_dir.empty() ? std::nullopt : std::optional<std::string>(output_dir),
                      append_output);
  });
}
