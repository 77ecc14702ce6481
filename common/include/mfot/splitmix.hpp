#pragma once
// SplitMix64 (Steele, Lea and Flood 2014): a counter-based generator. Its finaliser is a bijective mixer
// whose outputs pass as independent uniform 64-bit words for consecutive inputs, so a draw keyed by what
// it is for (a frame's seq, a pixel's index) depends on that key and the seed alone, never on the
// order of the draws before it.

#include <cstdint>

namespace mfot {

// The finaliser: the word for counter z.
inline std::uint64_t mix64(std::uint64_t z) {
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// The next word of the sequence at state (advanced).
inline std::uint64_t splitmix64(std::uint64_t& state) {
  const std::uint64_t word = mix64(state);
  state += 0x9E3779B97F4A7C15ull;
  return word;
}

// The word's top 24 bits as a float in [0, 1).
inline float unit_interval(std::uint64_t word) { return static_cast<float>(word >> 40) * (1.f / 16777216.f); }

}  // namespace mfot
