#pragma once
// The GPU side of the CUDA JCSD evaluator behind a CUDA-free interface: cuda_jcsd_likelihood.cpp
// (host compiler, Eigen) packs the data, jcsd_device.cu (nvcc, no Eigen) owns the stream, the
// buffers and the kernels. Every failure throws std::runtime_error carrying cudaGetErrorString.

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

namespace mfot::cuda_detail {

// Number of CUDA devices, or -1 with the CUDA error text in *why (when why is not null).
int device_count(std::string* why);
// "NVIDIA H100 80GB HBM3 (sm_90, 132 SMs)"; throws on an invalid ordinal.
std::string device_description(int device);

// One hypothesis point as the kernel reads it: two 16-byte words. The host writes the bins and
// the weights; evaluate() turns the bins into the byte offsets of the kernel's grid planes and
// each weight w into the bits of a 16-bit float pair (w, w).
struct PointRecord {
  float x, y, z;          // camera frame, metres
  std::int32_t hue_bin;   // SMR bin receiving w_lo; (hue_bin + 1) % 6 receives w_hi
  float w_lo, w_hi;       // chromatic weights
  float w_gray;           // achromatic weight
  std::int32_t gray_bin;  // its bin: 6 (dark) or 7 (light)
};
static_assert(sizeof(PointRecord) == 32);

// One particle as the kernel reads it: u = A z + b maps a camera-frame point z to grid units
// (the inverse pose, minus the grid origin, over the cell size), rows [A_r0 b_0 | A_r1 b_1 | A_r2 b_2].
struct ParticleRecord {
  float m[12];
};
static_assert(sizeof(ParticleRecord) == 48);

struct DeviceTiming {
  float kernel_ms = 0.f;    // the scoring kernel alone (CUDA events)
  float transfer_ms = 0.f;  // upload of points and particles, kernel, download of scores (CUDA events)
  int splits = 0;           // the launch shape used: work items per tile of 16 particles
};

struct DeviceOptions {
  int device = 0;
  int splits =
      0;  // work items per tile of 16 particles (each scores a split of the points), [1, 64]; 0: chosen per call
};

// Where the host writes one frame: `points` PointRecords and `particles` ParticleRecords.
struct FrameStaging {
  PointRecord* points;
  ParticleRecord* particles;
};

class JcsdDevice {
 public:
  explicit JcsdDevice(const DeviceOptions& options);
  ~JcsdDevice();
  JcsdDevice(const JcsdDevice&) = delete;
  JcsdDevice& operator=(const JcsdDevice&) = delete;

  // Pinned host buffer for corners * 8 floats in the JcsdGrid layout. Waits until the previous
  // grid upload has left it.
  float* grid_staging(std::size_t corners);
  // Uploads the staged grid (asynchronously, on this object's stream) and expands it into the
  // kernel's layout. dims are the corners along x, y, z (each >= 2).
  void upload_grid(const std::array<int, 3>& dims);

  // Pinned host buffers for one frame, valid until the next stage_frame.
  FrameStaging stage_frame(std::size_t points, std::size_t particles);
  // Uploads the staged frame, scores it against the uploaded grid and writes the particle scores
  // to scores (host memory, `particles` floats). Blocks until done. points and particles are
  // the counts given to stage_frame, which must precede every evaluate.
  void evaluate(std::size_t points, std::size_t particles, float* scores);

  DeviceTiming last_timing() const;
  const std::string& description() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace mfot::cuda_detail
