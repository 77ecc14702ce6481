#pragma once
// The range check of an options struct's validate(): one message shape for every field.

#include <cmath>
#include <stdexcept>
#include <string>

namespace mfot {

// Throws std::invalid_argument "Owner.field must be in [low, high], got value" (or "(low, high]" when
// low_open) unless value is finite and within the range. The bounds are compared in the value's own
// type: a float field set to exactly 0.1 (or pi) is at its bound, not a rounding step above it.
template <class Value>
void require_in_range(const char* owner, const char* field, Value value, double low, double high, bool low_open) {
  const auto lo = static_cast<Value>(low);
  const auto hi = static_cast<Value>(high);
  if (!(std::isfinite(static_cast<double>(value)) && (low_open ? value > lo : value >= lo) && value <= hi)) {
    throw std::invalid_argument(std::string(owner) + "." + field + " must be in " + (low_open ? "(" : "[") +
                                std::to_string(low) + ", " + std::to_string(high) + "], got " +
                                std::to_string(static_cast<double>(value)));
  }
}

}  // namespace mfot
