// mfot-labels: a recorded run's label images (labels/<frame>.png), drawn from its lcm log after the
// run (LogLabelImages). scripts/mfot-run calls it once the group has stopped; it also redraws the
// images of any recorded run, a live camera's too.
//
//   mfot-labels --run runs/<run>            (reads <run>/mfot.lcmlog with <run>/config.yaml)
//
// Exit status: 0 when the whole log was read; 1 when it is not an LCM log or is cut or corrupt (the
// images of the frames before the bad event are still written; the message names its byte offset),
// or another failure; 2 for a refused configuration; 3 when an image cannot be written.

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <filesystem>
#include <iostream>
#include <thread>

#include "mfot/service/config.hpp"
#include "mfot/service/group_security.hpp"
#include "mfot/service/lcm_log_reader.hpp"
#include "mfot/service/lcm_util.hpp"
#include "mfot/service/log_label_images.hpp"
#include "mfot/service/message_authenticator.hpp"
#include "mfot/service/service_main.hpp"

namespace mfot::service {
namespace {

int draw_labels(const std::string& run_dir, const std::string& log_path, int threads) {
  MalformedCounter rejected;
  LogLabelImages images(run_dir, threads, rejected);
  LcmLogReader log(log_path);
  std::optional<LcmLogError> log_error;
  try {
    while (std::optional<LcmLogEvent> event = log.next()) images.add(*event);
  } catch (const LcmLogError& e) {
    log_error = e;  // the frames before it are still drawn
  }
  const LabelImageCounts counts = images.finish();
  std::cout << "mfot-labels: " << counts.written << " label images in " << run_dir << "/labels from " << log_path
            << " (" << log.events_read() << " events)\n";
  if (counts.without_frame + counts.without_scene + counts.mismatched + counts.undecodable > 0) {
    std::cout << "mfot-labels: segmentations without their frame " << counts.without_frame << ", without their scene "
              << counts.without_scene << ", with a label count not their scene's " << counts.mismatched
              << ", with an undecodable frame " << counts.undecodable << "\n";
  }
  const AuthCounts dropped = message_authenticator()->counts();
  if (dropped.foreign + dropped.forged + dropped.replayed > 0) {
    std::cout << "mfot-labels: messages not drawn: " << dropped.foreign << " of other groups, " << dropped.forged
              << " forged, " << dropped.replayed << " replayed\n";
  }
  if (rejected.total() > 0) {
    std::cout << "mfot-labels: " << rejected.total() << " messages rejected, the last: " << rejected.last() << "\n";
  }
  if (log_error) {
    spdlog::error("{}", log_error->what());
    return 1;
  }
  return 0;
}

}  // namespace
}  // namespace mfot::service

int main(int argc, char** argv) {
  using namespace mfot::service;
  CLI::App app{"mfot-labels: a recorded run's label images (labels/<frame>.png) from its lcm log"};
  std::string run_dir, log_path, config_path;
  int threads = 0;
  app.add_option("--run", run_dir, "the run folder: labels/ is written there")->required();
  app.add_option("--log", log_path, "the run's lcm log (default: <run>/mfot.lcmlog)");
  app.add_option("--config", config_path,
                 "the run's config, for its group id and key (default: <run>/config.yaml when present, else the "
                 "built-in defaults)");
  app.add_option("--threads", threads, "frames drawn side by side, 0 = one per core")->check(CLI::Range(0, 64));
  CLI11_PARSE(app, argc, argv);
  setup_logging("labels", 0);
  return run_service_main([&] {
    if (log_path.empty()) log_path = run_dir + "/mfot.lcmlog";
    if (config_path.empty() && std::filesystem::is_regular_file(run_dir + "/config.yaml")) {
      config_path = run_dir + "/config.yaml";
    }
    // The run's group and key: only its own messages are drawn (another group's on the same URL, or
    // forged ones, were recorded too).
    install_group_security(load_config_file(config_path));
    // A log is read after the fact: how old its messages are says nothing (group.max_message_age_s is for
    // live receivers); the group, the MAC and each sender's increasing sequence are still checked.
    message_authenticator()->set_max_age_us(0);
    const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    return draw_labels(run_dir, log_path, threads > 0 ? threads : std::min(cores, 64));
  });
}
