#pragma once
// Strict reading of the evaluator's CSV inputs: a header row naming the columns, then one record
// per line. Every problem (missing file, missing column, wrong field count, a field that is not
// a number) throws EvaluationError naming the file and line, so a bad recording is never
// evaluated silently.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace mfot::evaluate {

struct EvaluationError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Fields are separated by commas and trimmed of blanks; empty lines and lines starting with '#'
// are skipped. Quoting is not supported: no evaluator input contains commas inside a field.
class CsvTable {
 public:
  // Throws EvaluationError when the file cannot be read, is empty, or lacks a required column.
  static CsvTable read(const std::filesystem::path& path, const std::vector<std::string>& required_columns);

  const std::filesystem::path& path() const { return path_; }
  const std::vector<std::string>& columns() const { return columns_; }
  std::size_t rows() const { return rows_.size(); }
  bool has_column(const std::string& name) const;
  std::size_t column(const std::string& name) const;  // throws when absent

  int line(std::size_t row) const { return lines_[row]; }  // 1-based line in the file
  const std::string& text(std::size_t row, std::size_t column) const { return rows_[row][column]; }
  // Finite number; throws "<file>:<line>: column '<name>': '<text>' is not a number".
  double number(std::size_t row, std::size_t column) const;
  // Whole number in [min, max].
  std::int64_t integer(std::size_t row, std::size_t column, std::int64_t min, std::int64_t max) const;
  // 0/1 or false/true.
  bool boolean(std::size_t row, std::size_t column) const;

  // "<file>:<line>: " for messages about one row.
  std::string where(std::size_t row) const;

 private:
  std::filesystem::path path_;
  std::vector<std::string> columns_;
  std::vector<std::vector<std::string>> rows_;
  std::vector<int> lines_;
};

}  // namespace mfot::evaluate
