// Run-time choice of the likelihood backend: CUDA JCSD (with the CPU JCSD as per-frame fallback),
// CPU JCSD or the point-to-point baseline. Builds without CUDA compile the same interface.
// Contract: `auto` takes the GPU when one can start and otherwise the CPU JCSD, with a note saying
// why; an explicit `cuda` that cannot start (no CUDA in the build, no device, a bad ordinal) throws
// std::runtime_error naming the reason: a robot configured for the GPU must not run silently slower.

#include "mfot/cuda/likelihood_factory.hpp"

#include "mfot/cuda/fallback_likelihood.hpp"
#include "mfot/jcsd_likelihood.hpp"
#include "mfot/point_to_point_likelihood.hpp"

#if MFOT_HAVE_CUDA
#include "jcsd_device.cuh"
#include "mfot/cuda/cuda_jcsd_likelihood.hpp"
#endif

#include <stdexcept>
#include <string>

namespace mfot {

LikelihoodBackend parse_likelihood_backend(std::string_view name) {
  if (name == "auto") return LikelihoodBackend::kAuto;
  if (name == "cuda") return LikelihoodBackend::kCuda;
  if (name == "cpu") return LikelihoodBackend::kCpu;
  if (name == "point-to-point") return LikelihoodBackend::kPointToPoint;
  throw std::invalid_argument("likelihood backend '" + std::string(name) +
                              "' is not one of auto|cuda|cpu|point-to-point");
}
namespace {

void validate(const LikelihoodOptions& options) {
  switch (options.backend) {
    case LikelihoodBackend::kAuto:
    case LikelihoodBackend::kCuda:
    case LikelihoodBackend::kCpu:
    case LikelihoodBackend::kPointToPoint:
      break;
    default:
      throw std::invalid_argument("LikelihoodOptions.backend must be kAuto, kCuda, kCpu or kPointToPoint");
  }
  validate(options.grid);
  if (options.cpu_threads < 1 || options.cpu_threads > 256) {
    throw std::invalid_argument("LikelihoodOptions.cpu_threads must be in [1, 256], got " +
                                std::to_string(options.cpu_threads));
  }
  if (options.cuda_device < 0) {
    throw std::invalid_argument("LikelihoodOptions.cuda_device must be >= 0, got " +
                                std::to_string(options.cuda_device));
  }
}

}  // namespace

bool cuda_available(std::string* why) {
#if MFOT_HAVE_CUDA
  std::string error;
  const int count = cuda_detail::device_count(&error);
  if (count < 0) {
    if (why != nullptr) *why = "no usable CUDA device: " + error;
    return false;
  }
  if (count == 0) {
    if (why != nullptr) *why = "no CUDA device present";
    return false;
  }
  return true;
#else
  if (why != nullptr) *why = "this build has no CUDA support (no nvcc at configure time, or MFOT_CUDA=OFF)";
  return false;
#endif
}

LikelihoodChoice make_likelihood(const LikelihoodOptions& options) {
  validate(options);
  const auto make_cpu = [&] {
    return std::make_unique<JcsdLikelihood>(JcsdLikelihoodOptions{options.grid, options.cpu_threads});
  };
  const std::string threads = std::to_string(options.cpu_threads) + " thread(s)";
  switch (options.backend) {
    case LikelihoodBackend::kCpu:
      return {make_cpu(), "jcsd-cpu", "cpu requested: CPU JCSD, " + threads};
    case LikelihoodBackend::kPointToPoint:
      return {std::make_unique<PointToPointLikelihood>(), "point-to-point",
              "point-to-point requested: [CC13] baseline on the CPU"};
    case LikelihoodBackend::kAuto:
    case LikelihoodBackend::kCuda:
      break;
  }
  const std::string asked = options.backend == LikelihoodBackend::kAuto ? "auto" : "cuda requested";
  std::string why;
#if MFOT_HAVE_CUDA
  if (cuda_available(&why)) {
    try {
      CudaJcsdLikelihoodOptions gpu_options;
      gpu_options.grid = options.grid;
      gpu_options.device = options.cuda_device;
      auto gpu = std::make_unique<CudaJcsdLikelihood>(gpu_options);
      std::string note = asked + ": CUDA JCSD on device " + std::to_string(options.cuda_device) + ", " +
                         gpu->device_description() + "; the CPU JCSD (" + threads + ") scores any frame the GPU fails";
      return {std::make_unique<FallbackLikelihood>(std::move(gpu), make_cpu()), "jcsd-cuda", std::move(note)};
    } catch (const std::runtime_error& error) {
      why = error.what();
    }
  }
#else
  cuda_available(&why);
#endif
  if (options.backend == LikelihoodBackend::kCuda) {
    throw std::runtime_error("likelihood backend 'cuda' requested but CUDA cannot start on device " +
                             std::to_string(options.cuda_device) + ": " + why +
                             " (set tracker.backend to auto or cpu to run on the CPU)");
  }
  return {make_cpu(), "jcsd-cpu", asked + ": CPU JCSD (" + threads + "), CUDA not used: " + why};
}

}  // namespace mfot
