#include "mfot/service/options.hpp"

#include <algorithm>
#include <sstream>

namespace mfot::service {

namespace {

constexpr std::size_t kWidth = 120;  // the generated YAML's line width

std::size_t depth_of(std::string_view key) { return static_cast<std::size_t>(std::count(key.begin(), key.end(), '.')); }

std::string_view leaf_of(std::string_view key) {
  const auto dot = key.rfind('.');
  return dot == std::string_view::npos ? key : key.substr(dot + 1);
}

// Greedy word wrap of one paragraph into lines of at most `width` characters (a longer word stands alone).
std::vector<std::string> wrap(std::string_view text, std::size_t width) {
  std::vector<std::string> lines;
  std::string line;
  std::istringstream words{std::string(text)};
  std::string word;
  while (words >> word) {
    if (!line.empty() && line.size() + 1 + word.size() > width) {
      lines.push_back(line);
      line.clear();
    }
    line += (line.empty() ? "" : " ") + word;
  }
  if (!line.empty() || lines.empty()) lines.push_back(line);
  return lines;
}

// A comment block at `indent`: every '\n'-separated paragraph wrapped.
void comment_block(std::string& out, std::size_t indent, std::string_view text) {
  std::size_t start = 0;
  while (start <= text.size()) {
    const auto end = std::min(text.find('\n', start), text.size());
    const std::string_view paragraph = text.substr(start, end - start);
    for (const auto& line : wrap(paragraph, kWidth - indent - 2)) {
      out += std::string(indent, ' ') + (line.empty() ? "#" : "# " + line) + "\n";
    }
    start = end + 1;
  }
}

// `head` followed by a comment starting at the comment column, continued on lines of their own.
void line_with_comment(std::string& out, std::string head, std::size_t indent, std::string_view comment) {
  if (comment.empty()) {
    out += head + "\n";
    return;
  }
  const std::size_t column = std::max<std::size_t>(28, 26 + indent);
  head += head.size() + 1 < column ? std::string(column - head.size(), ' ') : std::string("  ");
  const auto first = wrap(comment, kWidth - head.size() - 2);
  out += head + "# " + first.front() + "\n";
  if (first.size() == 1) return;
  // The rest re-wrapped at the comment column.
  std::string rest;
  for (std::size_t i = 1; i < first.size(); ++i) rest += (rest.empty() ? "" : " ") + first[i];
  for (const auto& line : wrap(rest, kWidth - column - 2)) out += std::string(column, ' ') + "# " + line + "\n";
}

// What an option's comment says: "<range> <unit>: <doc>".
std::string option_comment(const OptionEntry& o) {
  std::string prefix = option_range_text(o);
  if (!o.unit.empty()) prefix.append(prefix.empty() ? "" : " ").append(o.unit);
  if (prefix.empty()) return std::string(o.doc);
  if (o.doc.empty()) return prefix;
  return prefix.append(": ").append(o.doc);
}

std::string markdown_cell(std::string_view text) {
  std::string out;
  for (const char c : text) {
    if (c == '|')
      out += "\\|";
    else if (c == '<')
      out += "&lt;";
    else if (c == '\n')
      out += ' ';
    else
      out += c;
  }
  return out;
}

}  // namespace

const OptionEntry& option_spec(std::string_view key) {
  for (const auto& entry : option_table()) {
    if (entry.kind == OptionEntry::Kind::kOption && entry.key == key) return entry;
  }
  throw std::logic_error("no option is declared as " + std::string(key) + " (services/common/src/option_table.cpp)");
}

std::vector<std::string> option_choices(const OptionEntry& option) {
  std::vector<std::string> out;
  std::string_view rest = option.choices;
  while (!rest.empty()) {
    const auto bar = std::min(rest.find('|'), rest.size());
    out.emplace_back(rest.substr(0, bar));
    rest = bar < rest.size() ? rest.substr(bar + 1) : std::string_view();
  }
  return out;
}

std::string option_range_text(const OptionEntry& o) {
  if (o.type == OptionType::kChoice) {
    std::string out;
    for (const auto& c : option_choices(o)) out.append(out.empty() ? "" : " | ").append(c);
    return out;
  }
  // Built with append: GCC 12 at -O3 reports a false -Wrestrict on `"literal" + std::string&&`.
  std::string out;
  if (o.min.empty() && o.max.empty()) return out;
  if (o.max.empty()) return out.append(o.min_open ? "> " : ">= ").append(o.min);
  if (o.min.empty()) return out.append("<= ").append(o.max);
  return out.append(o.min_open ? "(" : "[").append(o.min).append(", ").append(o.max).append("]");
}

std::string read_choice(ConfigSection& s, const std::string& key) {
  const OptionEntry& spec = option_spec(s.path() + "." + key);
  if (spec.type != OptionType::kChoice) throw std::logic_error(s.path() + "." + key + ": not declared a choice");
  return s.choice(key, option_choices(spec));
}

std::vector<double> read_list(ConfigSection& s, const std::string& key) {
  const OptionEntry& spec = option_spec(s.path() + "." + key);
  if (spec.type != OptionType::kList) throw std::logic_error(s.path() + "." + key + ": not declared a list");
  return s.get_vector(key, static_cast<std::size_t>(spec.size));
}

std::string generate_default_yaml() {
  std::string out;
  for (const auto& e : option_table()) {
    switch (e.kind) {
      case OptionEntry::Kind::kBlank:
        out += "\n";
        break;
      case OptionEntry::Kind::kNote:
        comment_block(out, e.key.empty() ? 0 : 2 * (depth_of(e.key) + 1), e.doc);
        break;
      case OptionEntry::Kind::kMapping: {
        const std::size_t indent = 2 * depth_of(e.key);
        line_with_comment(out, std::string(indent, ' ') + std::string(leaf_of(e.key)) + ":", indent, e.doc);
        break;
      }
      case OptionEntry::Kind::kOption: {
        const std::size_t indent = 2 * depth_of(e.key);
        line_with_comment(out,
                          std::string(indent, ' ') + std::string(leaf_of(e.key)) + ": " + std::string(e.default_value),
                          indent, option_comment(e));
        break;
      }
    }
  }
  return out;
}

std::string generate_options_markdown() {
  std::string out =
      "# Configuration options\n\n"
      "Generated from services/common/src/option_table.cpp by `mfot-config --print-docs` (do not edit; "
      "tests/services/test_options.cpp checks it). configs/default.yaml is generated from the same table. "
      "Ranges are inclusive and are what the services accept: a value outside is refused at start with the "
      "key and the range. Units: metres, radians, milliseconds unless the Unit column says otherwise. A config of "
      "your own (--config) holds only what it changes and is laid over these defaults key by key.\n";
  bool in_table = false;
  bool intro = true;  // the table's first note is the file's header
  for (const auto& e : option_table()) {
    switch (e.kind) {
      case OptionEntry::Kind::kBlank:
        break;
      case OptionEntry::Kind::kNote: {
        if (intro) {
          intro = false;
          break;  // the YAML's header (how the file is laid over) has its own words above
        }
        in_table = false;
        std::string text(e.doc);
        std::replace(text.begin(), text.end(), '\n', ' ');
        out.append("\n").append(text).append("\n");
        break;
      }
      case OptionEntry::Kind::kMapping:
        in_table = false;
        out.append("\n").append(depth_of(e.key) == 0 ? "## `" : "### `").append(e.key).append("`\n");
        if (!e.doc.empty()) out.append("\n").append(e.doc).append("\n");
        break;
      case OptionEntry::Kind::kOption:
        if (!in_table) {
          out += "\n| Key | Default | Range | Unit | Meaning |\n|---|---|---|---|---|\n";
          in_table = true;
        }
        out += "| `" + std::string(e.key) + "` | `" + markdown_cell(e.default_value) + "` | " +
               markdown_cell(option_range_text(e)) + " | " + std::string(e.unit) + " | " + markdown_cell(e.doc) +
               " |\n";
        break;
    }
  }
  return out;
}

}  // namespace mfot::service
