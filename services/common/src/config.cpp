#include "mfot/service/config.hpp"

#include <algorithm>
#include <sstream>

namespace mfot::service {

const std::vector<std::string>& known_sections() {
  static const std::vector<std::string> sections = {"group",   "capture", "preprocess",
                                                    "tracker", "merger",  "pcl_baseline"};
  return sections;
}

YAML::Node default_config() {
  static const YAML::Node parsed = YAML::Load(default_config_text());
  return YAML::Clone(parsed);
}

namespace {
// Fills what `user` lacks from `defaults`, in place (the user's nodes keep their line numbers for
// error messages).
void fill_defaults(YAML::Node user, const YAML::Node& defaults) {
  for (const auto& item : defaults) {
    const std::string key = item.first.Scalar();
    YAML::Node mine = user[key];
    if (!mine || mine.IsNull()) {
      user[key] = YAML::Clone(item.second);
    } else if (mine.IsMap() && item.second.IsMap()) {
      fill_defaults(mine, item.second);
    }
  }
}
}  // namespace

YAML::Node merged_over_defaults(const YAML::Node& user) {
  if (!user || !user.IsMap()) return default_config();
  YAML::Node merged = user;
  fill_defaults(merged, default_config());
  return merged;
}

YAML::Node load_config_file(const std::string& path) {
  if (path.empty()) return default_config();
  try {
    YAML::Node root = YAML::LoadFile(path);
    if (root.IsNull()) return default_config();
    if (!root.IsMap()) throw ConfigError(path + ": the top level must be a mapping of service sections");
    try {
      check_top_level(root, known_sections());
    } catch (const ConfigError& e) {
      throw ConfigError(path + ": " + e.what());
    }
    return merged_over_defaults(root);
  } catch (const YAML::BadFile&) {
    throw ConfigError(path + ": cannot open config file");
  } catch (const YAML::ParserException& e) {
    throw ConfigError(path + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax error: " + e.msg);
  }
}

ConfigSection::ConfigSection(YAML::Node node, std::string path) : node_(std::move(node)), path_(std::move(path)) {
  if (node_ && !node_.IsNull() && !node_.IsMap()) {
    throw ConfigError(path_ + ": expected a mapping" + line_of(node_));
  }
}

bool ConfigSection::has(const std::string& key) const { return node_ && node_.IsMap() && node_[key]; }

YAML::Node ConfigSection::lookup(const std::string& key) {
  read_.insert(key);
  if (!node_ || !node_.IsMap()) return YAML::Node();
  const YAML::Node value = node_[key];
  if (!value || value.IsNull()) return YAML::Node();
  return value;
}

ConfigError ConfigSection::missing(const std::string& key) const {
  return ConfigError(qualified(key) +
                     ": missing (configs/default.yaml gives every key its default; this build's lacks it)");
}

std::string ConfigSection::choice(const std::string& key, const std::vector<std::string>& allowed) {
  const std::string value = get<std::string>(key);
  if (std::find(allowed.begin(), allowed.end(), value) == allowed.end()) {
    std::string list;
    for (const auto& a : allowed) list += (list.empty() ? "" : "|") + a;
    throw ConfigError(qualified(key) + ": '" + value + "' is not one of " + list + line_of(lookup(key)));
  }
  return value;
}

std::vector<double> ConfigSection::get_vector(const std::string& key, std::size_t size) {
  const YAML::Node value = lookup(key);
  if (!value || value.IsNull()) throw missing(key);
  if (!value.IsSequence() || value.size() != size) {
    throw ConfigError(qualified(key) + ": expected a list of " + std::to_string(size) + " numbers" + line_of(value));
  }
  std::vector<double> out;
  for (const auto& item : value) {
    try {
      out.push_back(item.as<double>());
    } catch (const YAML::Exception&) {
      throw ConfigError(qualified(key) + ": expected numbers, got '" + scalar_text(item) + "'" + line_of(item));
    }
  }
  return out;
}

ConfigSection ConfigSection::section(const std::string& key) { return ConfigSection(lookup(key), qualified(key)); }

void ConfigSection::finish() const {
  if (!node_ || !node_.IsMap()) return;
  std::string unknown;
  for (const auto& item : node_) {
    const auto key = scalar_text(item.first);  // a key may be a sequence or mapping ("? [a, b]: 1")
    if (!read_.count(key)) unknown += (unknown.empty() ? "" : ", ") + qualified(key) + line_of(item.first);
  }
  if (!unknown.empty()) throw ConfigError("unknown config key(s): " + unknown);
}

std::string ConfigSection::scalar_text(const YAML::Node& node) {
  if (node.IsScalar()) return node.Scalar();
  std::ostringstream s;
  s << node;
  return s.str();
}

std::string ConfigSection::line_of(const YAML::Node& node) {
  if (!node || node.Mark().line < 0) return "";
  return " (line " + std::to_string(node.Mark().line + 1) + ")";
}

ConfigSection config_section(const YAML::Node& root, const std::string& name) {
  return ConfigSection(root ? root[name] : YAML::Node(), name);
}

void check_top_level(const YAML::Node& root, const std::vector<std::string>& known_sections) {
  if (!root || !root.IsMap()) return;
  for (const auto& item : root) {
    // A sequence or mapping key ("? [a, b]: 1") is never a known section.
    const auto key = item.first.IsScalar() ? item.first.Scalar() : std::string("<non-scalar key>");
    if (std::find(known_sections.begin(), known_sections.end(), key) == known_sections.end()) {
      std::string list;
      for (const auto& k : known_sections) list += (list.empty() ? "" : "|") + k;
      throw ConfigError("unknown config section '" + key + "' (line " + std::to_string(item.first.Mark().line + 1) +
                        "): the sections are " + list);
    }
  }
}

}  // namespace mfot::service
