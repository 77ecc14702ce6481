// The core's option structs against the declarations (services/common/src/option_table.cpp): a
// library user who builds them in code should run what the services run.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <string>
#include <type_traits>

#include "mfot/service/config.hpp"
#include "mfot/service/options.hpp"
#include "mfot/service/pipeline_config.hpp"

namespace mfot::service {
namespace {

// The struct defaults that still differ from the declared (shipped) ones: the option structs keep
// the thesis's method there (features off, its values), and the core's tests build them that way.
// Moving them to the declared values means giving those tests the thesis's values explicitly; until
// then they are listed here, and the list may only shrink: a listed key whose struct default comes to
// agree fails too (take it off the list).
const std::set<std::string> kStructKeepsTheThesis = {
    "tracker.merger_timeout_ms",  // 0 in the struct: tests take models from any merger
    "merger.resume_listen_ms",    // 0 in the struct: tests finish frames without waiting for resumed objects
    "preprocess.plane_margin_sigmas",
    "preprocess.table_prism",
    "preprocess.queue_frames",
    "tracker.particles",
    "tracker.icp_iterations",
    "tracker.queue_scenes",
    "merger.alpha",
    "merger.propagation_min_seed_share",
    "merger.discovery.seed_resolution",
};

template <class T>
void expect_same(const T& loaded, const T& plain, const char* key) {
  const bool agree = [&] {
    if constexpr (std::is_floating_point_v<T>) {
      return std::abs(static_cast<double>(loaded) - static_cast<double>(plain)) <=
             1e-6 * std::max(1.0, std::abs(static_cast<double>(loaded)));
    } else {
      return loaded == plain;
    }
  }();
  if (kStructKeepsTheThesis.count(key)) {
    EXPECT_FALSE(agree) << key
                        << ": the option struct's default now agrees with the declared one: take it off "
                           "kStructKeepsTheThesis";
  } else {
    const auto text = [](const T& v) {
      if constexpr (std::is_enum_v<T>) {
        return std::to_string(static_cast<int>(v));
      } else {
        return ::testing::PrintToString(v);
      }
    };
    EXPECT_TRUE(agree) << key << ": the option struct's default " << text(plain) << " differs from the declared "
                       << text(loaded) << " (services/common/src/option_table.cpp)";
  }
}

// Every key the loaders read straight into an option struct field: the default the loader gives it
// (the declared one) against the field's own default.
TEST(OptionDefaults, TheOptionStructsDefaultToTheDeclaredValues) {
  const YAML::Node defaults = default_config();
  const PreprocessConfig loaded_preprocess = load_preprocess_config(defaults);
  const PreprocessConfig plain_preprocess;
  const TrackerConfig loaded_tracker = load_tracker_config(defaults);
  const TrackerConfig plain_tracker;
  const MergerConfig loaded_merger = load_merger_config(defaults);
  const MergerConfig plain_merger;
#include "option_defaults.inc"
  // The tracker key read by a helper (and by both loaders).
  expect_same(loaded_tracker.likelihood.grid.cell_size, plain_tracker.likelihood.grid.cell_size, "tracker.cell_size");
  expect_same(loaded_merger.manager.registration.cell_size, plain_merger.manager.registration.cell_size,
              "tracker.cell_size");
}

}  // namespace
}  // namespace mfot::service
