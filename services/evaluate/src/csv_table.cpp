#include "mfot/evaluate/csv_table.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <system_error>

namespace mfot::evaluate {

namespace {

std::string trim(const std::string& s) {
  const auto begin = s.find_first_not_of(" \t\r");
  if (begin == std::string::npos) return {};
  const auto end = s.find_last_not_of(" \t\r");
  return s.substr(begin, end - begin + 1);
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> fields;
  std::size_t start = 0;
  while (true) {
    const auto comma = line.find(',', start);
    fields.push_back(trim(line.substr(start, comma == std::string::npos ? std::string::npos : comma - start)));
    if (comma == std::string::npos) return fields;
    start = comma + 1;
  }
}

}  // namespace

CsvTable CsvTable::read(const std::filesystem::path& path, const std::vector<std::string>& required_columns) {
  std::ifstream in(path);
  if (!in) throw EvaluationError(path.string() + ": cannot open file");
  CsvTable table;
  table.path_ = path;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    const std::string content = trim(line);
    if (content.empty() || content.front() == '#') continue;
    auto fields = split(content);
    if (table.columns_.empty()) {
      table.columns_ = std::move(fields);
      for (std::size_t i = 0; i < table.columns_.size(); ++i) {
        if (table.columns_[i].empty()) {
          throw EvaluationError(path.string() + ":" + std::to_string(number) + ": header has an empty column name");
        }
        if (std::count(table.columns_.begin(), table.columns_.end(), table.columns_[i]) > 1) {
          throw EvaluationError(path.string() + ":" + std::to_string(number) + ": column '" + table.columns_[i] +
                                "' appears twice in the header");
        }
      }
      continue;
    }
    if (fields.size() != table.columns_.size()) {
      throw EvaluationError(path.string() + ":" + std::to_string(number) + ": expected " +
                            std::to_string(table.columns_.size()) + " fields, got " + std::to_string(fields.size()));
    }
    table.rows_.push_back(std::move(fields));
    table.lines_.push_back(number);
  }
  if (in.bad()) throw EvaluationError(path.string() + ": read error");
  if (table.columns_.empty()) throw EvaluationError(path.string() + ": empty file (no header row)");
  for (const auto& name : required_columns) {
    if (!table.has_column(name)) {
      throw EvaluationError(path.string() + ":1: missing column '" + name + "' in the header");
    }
  }
  return table;
}

bool CsvTable::has_column(const std::string& name) const {
  return std::find(columns_.begin(), columns_.end(), name) != columns_.end();
}

std::size_t CsvTable::column(const std::string& name) const {
  const auto it = std::find(columns_.begin(), columns_.end(), name);
  if (it == columns_.end()) throw EvaluationError(path_.string() + ": missing column '" + name + "'");
  return static_cast<std::size_t>(it - columns_.begin());
}

std::string CsvTable::where(std::size_t row) const { return path_.string() + ":" + std::to_string(lines_[row]) + ": "; }

double CsvTable::number(std::size_t row, std::size_t column) const {
  const std::string& s = rows_[row][column];
  double value = 0.0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  if (s.empty() || ec != std::errc() || end != s.data() + s.size() || !std::isfinite(value)) {
    throw EvaluationError(where(row) + "column '" + columns_[column] + "': '" + s + "' is not a finite number");
  }
  return value;
}

std::int64_t CsvTable::integer(std::size_t row, std::size_t column, std::int64_t min, std::int64_t max) const {
  const std::string& s = rows_[row][column];
  std::int64_t value = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  if (s.empty() || ec != std::errc() || end != s.data() + s.size()) {
    throw EvaluationError(where(row) + "column '" + columns_[column] + "': '" + s + "' is not an integer");
  }
  if (value < min || value > max) {
    throw EvaluationError(where(row) + "column '" + columns_[column] + "': " + s + " is out of range [" +
                          std::to_string(min) + ", " + std::to_string(max) + "]");
  }
  return value;
}

bool CsvTable::boolean(std::size_t row, std::size_t column) const {
  const std::string& s = rows_[row][column];
  if (s == "0" || s == "false") return false;
  if (s == "1" || s == "true") return true;
  throw EvaluationError(where(row) + "column '" + columns_[column] + "': '" + s + "' is not 0/1/false/true");
}

}  // namespace mfot::evaluate
