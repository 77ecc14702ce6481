// Likelihood normalisation of particle scores, thesis 3.3, equation 3.21.

#include "mfot/likelihood.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace mfot {

void likelihood_weights(std::span<const float> scores, float lambda, std::span<float> weights) {
  if (!(std::isfinite(lambda) && lambda > 0.f)) {
    throw std::invalid_argument("likelihood_weights: lambda must be finite and > 0, got " + std::to_string(lambda));
  }
  if (scores.size() != weights.size()) {
    throw std::invalid_argument("likelihood_weights: scores and weights differ in length");
  }
  if (scores.empty()) return;
  float s_min = std::numeric_limits<float>::infinity();
  float s_max = -std::numeric_limits<float>::infinity();
  for (const float s : scores) {
    if (!std::isfinite(s)) continue;
    s_min = std::min(s_min, s);
    s_max = std::max(s_max, s);
  }
  const float uniform = 1.f / static_cast<float>(scores.size());
  if (!(s_max > s_min)) {
    std::fill(weights.begin(), weights.end(), uniform);
    return;
  }
  // Written in place (no scratch allocation); the total is accumulated in double.
  const double range = static_cast<double>(s_max) - s_min;
  double total = 0.0;
  for (std::size_t i = 0; i < scores.size(); ++i) {
    const double s = std::isfinite(scores[i]) ? scores[i] : s_min;
    const double w = std::exp(-static_cast<double>(lambda) * (1.0 - (s - s_min) / range));
    weights[i] = static_cast<float>(w);
    total += w;
  }
  const float inv_total = static_cast<float>(1.0 / total);
  for (float& w : weights) w *= inv_total;
}

}  // namespace mfot
