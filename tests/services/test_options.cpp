// The option table (services/common/src/option_table.cpp) is the one declaration of every option:
// these tests fail when the shipped files, the loaders' ranges or the option structs' defaults
// disagree with it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <type_traits>

#include "mfot/capture/capture_settings.hpp"
#include "mfot/service/config.hpp"
#include "mfot/service/options.hpp"
#include "mfot/service/pipeline_config.hpp"
#include "mfot/sim/simulator.hpp"

namespace mfot::service {
namespace {

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

const std::string kRegenerate =
    "\nRegenerate the shipped files from the option table: build/services/config/mfot-config --print-defaults > "
    "configs/default.yaml; build/services/config/mfot-config --print-docs > docs/options.md";

TEST(Options, TheShippedDefaultYamlIsGeneratedFromTheTable) {
  const std::string committed = read_text(std::string(MFOT_SOURCE_DIR) + "/configs/default.yaml");
  EXPECT_EQ(committed, generate_default_yaml()) << "configs/default.yaml differs from the option table" << kRegenerate;
  // The build embeds the file: the services' defaults are the table's.
  EXPECT_EQ(std::string(default_config_text()), generate_default_yaml()) << "re-run cmake after regenerating";
}

TEST(Options, TheOptionsDocIsGeneratedFromTheTable) {
  const std::string committed = read_text(std::string(MFOT_SOURCE_DIR) + "/docs/options.md");
  EXPECT_EQ(committed, generate_options_markdown()) << "docs/options.md differs from the option table" << kRegenerate;
}

// Every option's declaration is complete and its default lies in its own range.
TEST(Options, EveryDeclarationIsCompleteAndItsDefaultInRange) {
  std::set<std::string> keys;
  int options = 0;
  const YAML::Node defaults = YAML::Load(generate_default_yaml());
  for (const auto& o : option_table()) {
    if (o.kind != OptionEntry::Kind::kOption) continue;
    ++options;
    const std::string key(o.key);
    EXPECT_TRUE(keys.insert(key).second) << key << " is declared twice";
    EXPECT_FALSE(o.default_value.empty()) << key;
    EXPECT_FALSE(o.doc.empty() && option_range_text(o).empty()) << key << " has neither a doc nor a range";
    // The default as the YAML parses it.
    YAML::Node node = defaults;
    std::stringstream path(key);
    std::string part;
    std::vector<YAML::Node> chain{defaults};
    while (std::getline(path, part, '.')) chain.push_back(chain.back()[part]);
    const YAML::Node value = chain.back();
    ASSERT_TRUE(value.IsDefined()) << key;
    switch (o.type) {
      case OptionType::kBool:
        EXPECT_NO_THROW((void)value.as<bool>()) << key;
        break;
      case OptionType::kInteger:
      case OptionType::kNumber: {
        double v = 0;
        if (o.type == OptionType::kInteger) {
          ASSERT_NO_THROW(v = static_cast<double>(value.as<long long>())) << key << " is not an integer";
        } else {
          ASSERT_NO_THROW(v = value.as<double>()) << key;
        }
        if (o.min_open) {
          EXPECT_GT(v, std::stod(std::string(o.min))) << key;
        }
        if (!o.min.empty()) {
          EXPECT_GE(v, std::stod(std::string(o.min))) << key;
        }
        if (!o.max.empty()) {
          EXPECT_LE(v, std::stod(std::string(o.max))) << key;
        }
        if (!o.min.empty() && !o.max.empty()) {
          EXPECT_LE(std::stod(std::string(o.min)), std::stod(std::string(o.max))) << key;
        }
        break;
      }
      case OptionType::kChoice: {
        const auto choices = option_choices(o);
        EXPECT_NE(std::find(choices.begin(), choices.end(), value.as<std::string>()), choices.end()) << key;
        break;
      }
      case OptionType::kList:
        EXPECT_TRUE(value.IsSequence()) << key;
        EXPECT_EQ(value.size(), static_cast<std::size_t>(o.size)) << key;
        break;
      case OptionType::kString:
        EXPECT_NO_THROW((void)value.as<std::string>()) << key;
        break;
    }
  }
  EXPECT_GT(options, 100);  // the loop reached every declaration (116 after the prunes)
  EXPECT_THROW((void)option_spec("tracker.no_such_key"), std::logic_error);
}

// capture.scenario's declared choices are the simulator's scenarios.
TEST(Options, TheScenarioChoicesAreTheSimulatorsScenarios) {
  EXPECT_EQ(option_choices(option_spec("capture.scenario")), sim::scenario_names());
}

// The text of a number for YAML, exact enough to land on the side of a bound it is meant to.
std::string number_text(double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.9g", v);
  return buffer;
}

// Loads `key: value` over the defaults through the loader of the key's section.
void load_with(const std::string& key, const std::string& value) {
  std::vector<std::string> parts;
  std::stringstream path(key);
  std::string part;
  while (std::getline(path, part, '.')) parts.push_back(part);
  std::string yaml;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    yaml += std::string(2 * i, ' ') + parts[i] + ":" + (i + 1 == parts.size() ? " " + value : "") + "\n";
  }
  const YAML::Node root = merged_over_defaults(YAML::Load(yaml));
  const std::string& section = parts.front();
  if (section == "preprocess") (void)load_preprocess_config(root);
  if (section == "tracker") (void)load_tracker_config(root);
  if (section == "merger") (void)load_merger_config(root);
  if (section == "capture") capture::load_capture_settings(config_section(root, "capture")).validate();
}

// Keys whose bound the core refuses in a range that another key's value sets (none left: the method's constants
// fixed the other side of each).
const std::set<std::string> kCrossField = {};

// The loaders take their ranges from the declarations: just outside a declared bound is refused with
// the key and "out of range", and the bound itself is never refused as out of range (neither by the
// loader nor by the core's validate(), whose own range must admit the declared one).
TEST(Options, TheLoadersRefuseExactlyOutsideTheDeclaredRanges) {
  int checked = 0;
  for (const auto& o : option_table()) {
    if (o.kind != OptionEntry::Kind::kOption) continue;
    if (o.type != OptionType::kInteger && o.type != OptionType::kNumber) continue;
    const std::string key(o.key);
    const std::string section = key.substr(0, key.find('.'));
    if (section == "group" || section == "pcl_baseline") continue;  // read by scripts/mfot-run, mfot-pcl-baseline
    for (const bool upper : {false, true}) {
      const std::string_view bound = upper ? o.max : o.min;
      if (bound.empty()) continue;
      const double b = std::stod(std::string(bound));
      const double step = o.type == OptionType::kInteger ? 1.0 : std::max(1e-6, std::abs(b) * 1e-3);
      const bool open = !upper && o.min_open;  // (min, max]: min itself is outside
      const std::string outside = open ? std::string(bound) : number_text(upper ? b + step : b - step);
      const std::string inside = open ? number_text(b + step) : std::string(bound);
      try {
        load_with(key, outside);
        ADD_FAILURE() << key << ": " << outside << " outside " << option_range_text(o) << " was accepted";
      } catch (const ConfigError& e) {
        const std::string what = e.what();
        if (!upper && b == 0 && what.find(key + ": expected a non-negative integer") != std::string::npos) continue;
        EXPECT_NE(what.find(key + ": value"), std::string::npos) << what;
        EXPECT_NE(what.find("out of range"), std::string::npos) << what;
      } catch (const std::exception& e) {
        ADD_FAILURE() << key << ": " << e.what();
      }
      try {
        load_with(key, inside);
      } catch (const std::exception& e) {
        // Only a rule between two keys ("needs hold_occluded_share > 0") may refuse a bound; a range never
        // (the core's validate() says "must be in" for its ranges).
        const std::string what = e.what();
        EXPECT_EQ(what.find("out of range"), std::string::npos) << key << " = " << inside << ": " << what;
        EXPECT_TRUE(what.find("must be in") == std::string::npos || kCrossField.count(key))
            << key << " = " << inside << ": " << what;
      }
      ++checked;
    }
  }
  EXPECT_GT(checked, 80);  // the loop reached the bounds of every ranged option
}

}  // namespace
}  // namespace mfot::service
