#pragma once
// The one percentile of the project's timing figures (status latencies, benchmark and in-process
// summaries): the value at rank round(q (n - 1)) of the sorted values, 0 for none.

#include <algorithm>
#include <cstddef>
#include <vector>

namespace mfot {

// q in [0, 1].
inline double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(q * static_cast<double>(values.size() - 1) + 0.5);
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

}  // namespace mfot
