// Smoothed Color Ranging, thesis 3.2.1, equations 3.5 to 3.10 (ALGORITHM.md, "Colour feature").
// Steps per point: RGB -> HSV (3.5); chromatic weight w_C = S^(r * V^-r1), w_G = 1 - w_C (3.6);
// soft hue quantisation between the two nearest of the six hue representatives (3.7-3.9);
// hard dark/light split of the achromatic weight at V = 0.5 (3.10).

#include "mfot/smr_feature.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace mfot {
namespace {

void validate(const SmrOptions& options) {
  // The thesis restricts both exponents to [0, 1]; r = 0 would make every colour fully chromatic.
  if (!(options.r > 0.f && options.r <= 1.f)) {
    throw std::invalid_argument("SmrOptions.r must be in (0, 1], got " + std::to_string(options.r));
  }
  if (!(options.r1 >= 0.f && options.r1 <= 1.f)) {
    throw std::invalid_argument("SmrOptions.r1 must be in [0, 1], got " + std::to_string(options.r1));
  }
}

SmrFeature compute_smr_unchecked(Rgb8 color, const SmrOptions& options) {
  const float r = color.r / 255.f;
  const float g = color.g / 255.f;
  const float b = color.b / 255.f;
  const float max = std::max({r, g, b});
  const float min = std::min({r, g, b});
  const float value = max;
  const float saturation = max > 0.f ? 1.f - min / max : 0.f;

  // Hexcone hue in [0, 360); undefined (taken as 0) for greys, whose chromatic weight is 0 anyway.
  float hue = 0.f;
  const float chroma = max - min;
  if (chroma > 0.f) {
    if (max == r) {
      hue = 60.f * ((g - b) / chroma);
    } else if (max == g) {
      hue = 60.f * (2.f + (b - r) / chroma);
    } else {
      hue = 60.f * (4.f + (r - g) / chroma);
    }
    if (hue < 0.f) hue += 360.f;
    if (hue >= 360.f) hue -= 360.f;
  }

  const float chromatic = value > 0.f ? std::pow(saturation, options.r * std::pow(value, -options.r1)) : 0.f;
  const float achromatic = 1.f - chromatic;

  SmrFeature f;
  const int bin = std::min(static_cast<int>(hue / 60.f), 5);
  const float lo = (60.f * static_cast<float>(bin + 1) - hue) / 60.f;  // (R_n' - H) / 60, 3.8
  f.hue_bin = static_cast<std::uint8_t>(bin);
  f.hue_weight_lo = chromatic * lo;
  f.hue_weight_hi = chromatic * (1.f - lo);
  f.gray_bin = value < 0.5f ? 6 : 7;
  f.gray_weight = achromatic;
  return f;
}

}  // namespace

std::array<float, kSmrBins> SmrFeature::dense() const {
  std::array<float, kSmrBins> h{};
  h[hue_bin] += hue_weight_lo;
  h[(hue_bin + 1) % 6] += hue_weight_hi;
  h[gray_bin] += gray_weight;
  return h;
}

SmrFeature compute_smr(Rgb8 color, const SmrOptions& options) {
  validate(options);
  return compute_smr_unchecked(color, options);
}

std::vector<SmrFeature> compute_smr(std::span<const Rgb8> colors, const SmrOptions& options) {
  validate(options);
  std::vector<SmrFeature> features;
  features.reserve(colors.size());
  for (const Rgb8 c : colors) features.push_back(compute_smr_unchecked(c, options));
  return features;
}

}  // namespace mfot
