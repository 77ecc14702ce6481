#pragma once
// Chooses a likelihood backend at run time. Host code includes only this header: the CUDA
// implementation stays behind it, in cuda/src.

#include <memory>
#include <string>
#include <string_view>

#include "mfot/jcsd_grid.hpp"
#include "mfot/likelihood.hpp"

namespace mfot {

enum class LikelihoodBackend { kAuto, kCuda, kCpu, kPointToPoint };

// "auto" | "cuda" | "cpu" | "point-to-point" (tracker.backend, --backend); anything else throws
// std::invalid_argument naming the name and the choices.
LikelihoodBackend parse_likelihood_backend(std::string_view name);

struct LikelihoodOptions {
  LikelihoodBackend backend = LikelihoodBackend::kAuto;
  JcsdGridOptions grid;  // JCSD backends
  int cpu_threads = 1;   // JCSD CPU: threads across particles (>= 1)
  int cuda_device = 0;   // CUDA: device ordinal
};

struct LikelihoodChoice {
  std::unique_ptr<Likelihood> likelihood;  // never null
  std::string backend;                     // "jcsd-cuda", "jcsd-cpu" or "point-to-point"
  std::string note;                        // why this backend was chosen (e.g. the CUDA error text on fallback)
};

// Largest relative difference of a CUDA JCSD score from the CPU JCSD's (the reference): the GPU
// reads J as 16-bit floats and weights each corner's three bins (3.19) in 16-bit arithmetic,
// every rounding relative with unit 2^-11 on non-negative terms; at most five roundings per term
// bound the error by (1 + 2^-11)^5 - 1 < 2.5e-3, float rounding of the sums aside.
inline constexpr float kCudaJcsdRelativeError = 2.5e-3f;

// kAuto: CUDA when built with it and a device is present, else CPU JCSD (the reason in `note`).
// kCuda throws std::runtime_error naming the reason when no device can be used.
LikelihoodChoice make_likelihood(const LikelihoodOptions& options);

// True when this build has CUDA support and a CUDA device is usable; `why` explains a false.
bool cuda_available(std::string* why = nullptr);

}  // namespace mfot
