#pragma once
// Every configuration option declared once: its key, type, shipped default, allowed range (or
// choices), unit and meaning (option_table.cpp). From that one declaration the loaders take each
// key's range (read_option), and configs/default.yaml and docs/options.md are generated
// (mfot-config --print-defaults / --print-docs; tests/services/test_options.cpp fails when the
// committed files differ).

#include <cstdint>
#include <limits>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "mfot/service/config.hpp"

namespace mfot::service {

enum class OptionType { kBool, kInteger, kNumber, kString, kChoice, kList };

// One entry of the option table, in the order configs/default.yaml lists them. Besides options,
// the table holds the layout of the generated YAML: a mapping's line (`merger.carry:`), a comment
// paragraph and a blank line.
struct OptionEntry {
  enum class Kind { kOption, kMapping, kNote, kBlank };
  Kind kind = Kind::kBlank;
  // kOption and kMapping: the full dotted path ("tracker.max_hold_frames", "merger.carry"); kNote:
  // the mapping it stands in ("" = the top level), which sets its indentation.
  std::string_view key;
  OptionType type = OptionType::kString;
  std::string_view default_value;  // kOption: the YAML text of the shipped default
  // kInteger and kNumber: the inclusive bounds as written ("" = unbounded on that side).
  std::string_view min;
  std::string_view max;
  bool min_open = false;     // the lower bound itself is refused: (min, max]
  std::string_view choices;  // kChoice: "a|b|c"
  int size = 0;              // kList: the number of elements
  std::string_view unit;     // "m", "rad", "deg", "ms", "s" or "" (counts, shares, flags)
  std::string_view doc;      // kOption, kMapping: its meaning; kNote: a paragraph ('\n' breaks lines)
};

// The whole table, in file order.
std::span<const OptionEntry> option_table();

// The declaration of one option by its full path; std::logic_error when none (a loader reading a
// key nobody declared is a programming error).
const OptionEntry& option_spec(std::string_view key);

// "[lo, hi]", ">= lo", "<= hi" or "" for an entry's range; "a | b | c" for a choice.
std::string option_range_text(const OptionEntry& option);

// configs/default.yaml and docs/options.md as the table generates them.
std::string generate_default_yaml();
std::string generate_options_markdown();

std::vector<std::string> option_choices(const OptionEntry& option);

namespace detail {
template <class T>
T option_bound(std::string_view text, T unbounded) {
  if (text.empty()) return unbounded;
  const std::string s(text);
  if constexpr (std::is_floating_point_v<T>) {
    return static_cast<T>(std::stod(s));
  } else if constexpr (std::is_signed_v<T>) {
    return static_cast<T>(std::stoll(s));
  } else {
    return static_cast<T>(std::stoull(s));
  }
}
}  // namespace detail

// Reads `key` of section `s` with the type T and the range its declaration gives (out of range:
// ConfigError naming the key and the range, as ConfigSection::get).
template <class T>
T read_option(ConfigSection& s, const std::string& key) {
  const OptionEntry& spec = option_spec(s.path() + "." + key);
  if constexpr (std::is_same_v<T, bool>) {
    if (spec.type != OptionType::kBool) throw std::logic_error(s.path() + "." + key + ": not declared a flag");
    return s.get<bool>(key);
  } else if constexpr (std::is_same_v<T, std::string>) {
    if (spec.type != OptionType::kString) throw std::logic_error(s.path() + "." + key + ": not declared a string");
    return s.get<std::string>(key);
  } else {
    const bool integral = std::is_integral_v<T>;
    if (spec.type != (integral ? OptionType::kInteger : OptionType::kNumber)) {
      throw std::logic_error(s.path() + "." + key + ": declared with another type than it is read");
    }
    const T min = detail::option_bound<T>(spec.min, std::numeric_limits<T>::lowest());
    const T max = detail::option_bound<T>(spec.max, std::numeric_limits<T>::max());
    if (!spec.min_open) return s.get<T>(key, min, max);
    const T value = s.get<T>(key);
    if (!(value > min && value <= max)) {
      throw ConfigError(s.path() + "." + key + ": value " + std::to_string(value) + " is out of range (" +
                        std::to_string(min) + ", " + std::to_string(max) + "]");
    }
    return value;
  }
}

// A choice option: one of its declared choices.
std::string read_choice(ConfigSection& s, const std::string& key);
// A list option: its declared number of numbers.
std::vector<double> read_list(ConfigSection& s, const std::string& key);

}  // namespace mfot::service
