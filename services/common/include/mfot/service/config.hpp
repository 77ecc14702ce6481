#pragma once
// Strict YAML configuration: every key is read with its type and allowed range, and keys nobody
// reads are errors, so a typo in a config is refused at start instead of silently ignored.

#include <yaml-cpp/yaml.h>

#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace mfot::service {

struct ConfigError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The top-level sections a config file may have: the services' own, `group` (scripts/mfot-run)
// and `pcl_baseline` (mfot-pcl-baseline).
const std::vector<std::string>& known_sections();

// configs/default.yaml as built in: every key of every section with its default.
const char* default_config_text();
YAML::Node default_config();

// `user` laid over the defaults: mappings merge key by key, any other value (a list too) replaces
// the default; a null value leaves the default.
YAML::Node merged_over_defaults(const YAML::Node& user);

// Parses a YAML file and lays it over the defaults (an empty path: the defaults alone); throws
// ConfigError naming the file (and line for syntax errors), and when the top level has a section
// that is not one of known_sections() (a misspelt section would otherwise be ignored).
YAML::Node load_config_file(const std::string& path);

// A strict view of one YAML mapping. Reads record the key; finish() throws listing unknown keys.
class ConfigSection {
 public:
  ConfigSection(YAML::Node node, std::string path);

  const std::string& path() const { return path_; }
  bool has(const std::string& key) const;

  // Every key must be present: the loaders read configs laid over the defaults, so a missing key
  // is one that configs/default.yaml lacks.
  template <class T>
  T get(const std::string& key) {
    const YAML::Node value = lookup(key);
    if (!value || value.IsNull()) throw missing(key);  // lookup() gives a Null node for absent keys
    try {
      return value.as<T>();
    } catch (const YAML::Exception&) {
      throw ConfigError(qualified(key) + ": expected " + type_name<T>() + ", got '" + scalar_text(value) + "'" +
                        line_of(value));
    }
  }

  template <class T>
  T get(const std::string& key, T min, T max) {
    const T value = get<T>(key);
    if (!(value >= min && value <= max)) {
      throw ConfigError(qualified(key) + ": value " + to_text(value) + " is out of range [" + to_text(min) + ", " +
                        to_text(max) + "]" + line_of(lookup(key)));
    }
    return value;
  }

  std::string choice(const std::string& key, const std::vector<std::string>& allowed);
  std::vector<double> get_vector(const std::string& key, std::size_t size);
  ConfigSection section(const std::string& key);

  // Throws ConfigError naming every key of this mapping that was never read.
  void finish() const;

 private:
  YAML::Node lookup(const std::string& key);
  ConfigError missing(const std::string& key) const;
  std::string qualified(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }
  static std::string scalar_text(const YAML::Node& node);
  static std::string line_of(const YAML::Node& node);
  template <class T>
  static std::string type_name();
  template <class T>
  static std::string to_text(const T& v) {
    if constexpr (std::is_same_v<T, std::string>)
      return v;
    else
      return std::to_string(v);
  }

  YAML::Node node_;
  std::string path_;
  std::set<std::string> read_;
};

template <>
inline std::string ConfigSection::type_name<bool>() {
  return "a boolean";
}
template <>
inline std::string ConfigSection::type_name<int>() {
  return "an integer";
}
template <>
inline std::string ConfigSection::type_name<long>() {
  return "an integer";
}
template <>
inline std::string ConfigSection::type_name<long long>() {
  return "an integer";
}
template <>
inline std::string ConfigSection::type_name<unsigned long>() {
  return "a non-negative integer";
}
template <>
inline std::string ConfigSection::type_name<float>() {
  return "a number";
}
template <>
inline std::string ConfigSection::type_name<double>() {
  return "a number";
}
template <>
inline std::string ConfigSection::type_name<std::string>() {
  return "a string";
}

// The top-level mapping `name` of a config root (an empty section when absent). The root itself
// may only contain known service sections; see known_sections().
ConfigSection config_section(const YAML::Node& root, const std::string& name);

// Throws ConfigError when the root has a top-level key that is not a known section.
void check_top_level(const YAML::Node& root, const std::vector<std::string>& known_sections);

}  // namespace mfot::service
