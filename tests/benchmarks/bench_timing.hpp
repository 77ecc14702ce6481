#pragma once
// Wall-clock timing shared by the benchmark binaries: steady-clock milliseconds and the summary
// figures of a series of per-frame or per-call times.

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <utility>
#include <vector>

#include "mfot/percentile.hpp"

namespace mfot::bench {

using Clock = std::chrono::steady_clock;

inline double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

using mfot::percentile;

inline double median(std::vector<double> values) { return percentile(std::move(values), 0.5); }

struct Series {
  std::vector<double> values;
  void add(double v) { values.push_back(v); }
  double mean() const {
    double s = 0.0;
    for (const double v : values) s += v;
    return values.empty() ? 0.0 : s / static_cast<double>(values.size());
  }
  double percentile(double q) const { return bench::percentile(values, q); }
  double median() const { return bench::median(values); }
};

}  // namespace mfot::bench
