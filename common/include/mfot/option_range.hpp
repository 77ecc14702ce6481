#pragma once
// The range check of an options struct's validate(): one message shape for every field.

#include <cmath>
#include <stdexcept>
#include <string>

namespace mfot {

// Throws std::invalid_argument "Owner.field must be in [low, high], got value" (or "(low, high]" when
// low_open) unless value is finite and within the range.
inline void require_in_range(const char* owner, const char* field, double value, double low, double high,
                             bool low_open) {
  if (!(std::isfinite(value) && (low_open ? value > low : value >= low) && value <= high)) {
    throw std::invalid_argument(std::string(owner) + "." + field + " must be in " + (low_open ? "(" : "[") +
                                std::to_string(low) + ", " + std::to_string(high) + "], got " + std::to_string(value));
  }
}

}  // namespace mfot
