#pragma once
// JCSD hypothesis evaluation on a CUDA GPU, thesis 3.3, equations 3.18 to 3.20 (the GPU
// implementation the thesis timed in Table 4.1). Only in builds with CUDA (MFOT_HAVE_CUDA); host
// code reaches it through make_likelihood (likelihood_factory.hpp). No CUDA header here.

#include <memory>
#include <string>

#include "mfot/jcsd_grid.hpp"
#include "mfot/likelihood.hpp"

namespace mfot {

namespace cuda_detail {
class JcsdDevice;
}

struct CudaJcsdLikelihoodOptions {
  JcsdGridOptions grid;  // grid built from the model by set_model
  int device = 0;        // CUDA device ordinal, >= 0
  // Work items per tile of 16 particles, each scoring one split of the points, [1, 64]; 0
  // chooses per call from the particle and point counts and the device's multiprocessors.
  int point_splits = 0;
};

// Throws std::invalid_argument naming the field when an option is out of range.
void validate(const CudaJcsdLikelihoodOptions& options);

struct CudaJcsdTiming {
  float kernel_ms = 0.f;    // scoring kernel alone (CUDA events)
  float transfer_ms = 0.f;  // uploads, kernel and download of the scores (CUDA events)
  int point_splits = 0;     // the scoring kernel's launch shape
};

// Scores particles against the model's JCSD grid on the GPU. Steps:
//  1. set_model: build J on the CPU (Algorithm 3, build_jcsd_grid), copy it to pinned memory and
//     upload it asynchronously; the kernel reads it as padded planes of 16-bit floats
//     (jcsd_device.cu), expanded into shared memory by each block when they fit.
//  2. evaluate: pack the hypothesis points (position and sparse SMR, 32 B) and the particles
//     (inverse pose in grid units, 48 B) into one pinned buffer, upload it, run the scoring
//     kernel, download the scores; all on this object's own stream, then wait for it.
// Each instance owns its CUDA stream, device buffers and pinned staging buffers; buffers are
// allocated on first use and grow only when a larger input arrives (no allocation per frame).
// Instances, and processes, share a GPU without interfering. Every CUDA failure (no device, out
// of memory, failed launch) throws std::runtime_error with the CUDA error text, so the caller
// can fall back to the CPU (FallbackLikelihood). Scores match JcsdLikelihood, the reference, within
// kCudaJcsdRelativeError (likelihood_factory.hpp) relative.
class CudaJcsdLikelihood final : public Likelihood {
 public:
  explicit CudaJcsdLikelihood(const CudaJcsdLikelihoodOptions& options = {});
  ~CudaJcsdLikelihood() override;
  CudaJcsdLikelihood(const CudaJcsdLikelihood&) = delete;
  CudaJcsdLikelihood& operator=(const CudaJcsdLikelihood&) = delete;

  std::string_view name() const override { return "jcsd-cuda"; }
  void set_model(const ObjectModel& model) override;
  // Uses a grid built elsewhere (e.g. the one a CPU JcsdLikelihood already holds).
  void set_grid(JcsdGrid grid);
  const JcsdGrid& grid() const { return grid_; }

  void evaluate(std::span<const Pose> particles, const HypothesisData& data, std::span<float> scores) override;

  // Timing of the last evaluate that ran the kernel.
  CudaJcsdTiming last_timing() const;
  // e.g. "NVIDIA H100 80GB HBM3 (sm_90, 132 SMs)"
  const std::string& device_description() const;

 private:
  CudaJcsdLikelihoodOptions options_;
  std::unique_ptr<cuda_detail::JcsdDevice> device_;
  JcsdGrid grid_;
};

}  // namespace mfot
