// Fuzz target: the strict YAML config loader. The input is a config file's text: it is loaded
// with load_config_file (which refuses unknown sections), read by the services' real loaders
// (load_preprocess_config, load_tracker_config, load_merger_config, and load_capture_settings when
// mfot_capture is built), and the tracker/merger/preprocess/group
// sections are read through every ConfigSection path the services use (get<int|long|unsigned
// long|float|double|bool|string> with and without ranges, choice, get_vector, nested section,
// finish), each read on its own so one bad key does not hide the paths behind it.
// Contract checked: bad input only ever surfaces as ConfigError, never as another exception
// (e.g. a yaml-cpp conversion error), a crash or a sanitizer report.

#include "fuzz_support.hpp"
#include "mfot/service/config.hpp"
#include "mfot/service/pipeline_config.hpp"
#ifdef MFOT_FUZZ_HAVE_CAPTURE
#include "mfot/capture/capture_settings.hpp"
#endif

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace {

using mfot::service::ConfigError;
using mfot::service::ConfigSection;

template <class Read>
void read_or_config_error(Read&& read) {
  try {
    read();
  } catch (const ConfigError&) {
  }
}

void read_every_way(ConfigSection& s) {
  read_or_config_error([&] { s.get<int>("particles", 1, 100000); });
  read_or_config_error([&] { s.get<int>("heartbeat_ms"); });
  read_or_config_error([&] { s.get<long>("max_frames", 0L, 1000000L); });
  read_or_config_error([&] { s.get<unsigned long>("seed"); });
  read_or_config_error([&] { s.get<float>("lambda", 0.0f, 1000.0f); });
  read_or_config_error([&] { s.get<float>("cell_size"); });
  read_or_config_error([&] { s.get<double>("tau", 0.0, 1.0); });
  read_or_config_error([&] { s.get<double>("fps"); });
  read_or_config_error([&] { s.get<bool>("write_labels"); });
  read_or_config_error([&] { s.get<std::string>("backend"); });
  read_or_config_error([&] { s.choice("resampling", {"multinomial", "systematic"}); });
  read_or_config_error([&] { s.get_vector("init_sigma", 6); });
  read_or_config_error([&] {
    ConfigSection world = s.section("world");
    read_or_config_error([&] { world.get_vector("translation", 3); });
    read_or_config_error([&] { world.get_vector("rotation", 4); });
    world.finish();
  });
  read_or_config_error([&] { (void)s.has("unread"); });
  read_or_config_error([&] { s.finish(); });
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mfot::service;
  mfot::fuzz::silence_logging();
  const auto path = mfot::fuzz::scratch_folder() / "config.yaml";
  mfot::fuzz::write_file(path, data, size);
  YAML::Node root;
  try {
    root = load_config_file(path.string());
  } catch (const ConfigError&) {
    return 0;
  }
  MFOT_FUZZ_CHECK(root.IsMap());
  // load_config_file refuses unknown sections, so checking them again must pass.
  try {
    check_top_level(root, known_sections());
  } catch (const ConfigError&) {
    mfot::fuzz::fail("load_config_file accepted an unknown top-level section");
  }
  // The services' own loaders, with their cross-field checks.
  read_or_config_error([&] { load_preprocess_config(root); });
  read_or_config_error([&] { load_tracker_config(root); });
  read_or_config_error([&] { load_merger_config(root); });
#ifdef MFOT_FUZZ_HAVE_CAPTURE
  read_or_config_error([&] { mfot::capture::load_capture_settings(config_section(root, "capture")).validate(); });
#endif
  for (const char* name : {"tracker", "merger", "preprocess", "group"}) {
    read_or_config_error([&] {
      ConfigSection section = config_section(root, name);
      read_every_way(section);
    });
  }
  return 0;
}
