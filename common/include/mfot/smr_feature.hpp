#pragma once
// Smoothed Color Ranging colour feature, thesis 3.2.1, equations 3.5 to 3.10.

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "mfot/types.hpp"

namespace mfot {

inline constexpr int kSmrBins = 8;  // 6 chromatic hue bins + dark + light achromatic bin

// The 8-bin SMR vector of one point, stored sparsely: it has at most three non-zero entries,
// two neighbouring hue bins and one achromatic bin (ALGORITHM.md, "Colour feature").
struct SmrFeature {
  std::uint8_t hue_bin = 0;   // in [0, 6): receives hue_weight_lo; (hue_bin + 1) % 6 receives hue_weight_hi
  std::uint8_t gray_bin = 6;  // 6 (dark, V < 0.5) or 7 (light): receives gray_weight
  float hue_weight_lo = 0.f;
  float hue_weight_hi = 0.f;
  float gray_weight = 0.f;

  std::array<float, kSmrBins> dense() const;
};

struct SmrOptions {
  float r = 0.14f;  // exponent scale of the chromatic weight (3.6)
  float r1 = 0.9f;  // exponent of V in the chromatic weight (3.6)
};

SmrFeature compute_smr(Rgb8 color, const SmrOptions& options = {});
std::vector<SmrFeature> compute_smr(std::span<const Rgb8> colors, const SmrOptions& options = {});

}  // namespace mfot
