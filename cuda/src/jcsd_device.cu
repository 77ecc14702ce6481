// CUDA JCSD hypothesis evaluation, thesis 3.3, equations 3.18 to 3.20 (the GPU side; the host
// side packs the data in cuda_jcsd_likelihood.cpp). Steps:
//  1. upload_grid: the model's J (8 floats per corner) goes to the device through pinned memory
//     and is expanded into six hue-pair grids: for lower hue bin b, corner s holds the float4
//     (J(b, s), J((b + 1) % 6, s), J(6, s), J(7, s)). A point's SMR has at most three non-zero
//     bins (b, b + 1, one achromatic), so it correlates with a corner in one 16-byte load and one
//     4-term dot product (3.19), with its bin choice uniform across a warp (see 3).
//  2. evaluate: points (32 B) and particles (48 B, the inverse pose already in grid units) go to
//     the device with one asynchronous copy each from pinned memory, on this object's stream.
//  3. the scoring kernel: a warp holds 32 particles, one per lane, and walks a share of the
//     points. All lanes read the same point (a shared-memory broadcast), so the hue-pair grid is
//     warp-uniform, and the particles of a filter lie close together, so the 32 lanes land on the
//     same few cells and their 8 corner loads (3.18) share cache lines in L1 / L2. Each lane sums
//     its particle's score in a register (3.20); the 8 warps of a block split the points and are
//     added in shared memory in a fixed order; the blocks that split one particle group's points
//     write partial sums and the last to finish (one counter per group) adds them in a fixed
//     order. No floating-point atomics: scores are deterministic.

#include "jcsd_device.cuh"

#include <cuda_runtime.h>

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>

namespace mfot::cuda_detail {
namespace {

constexpr int kWarpSize = 32;
constexpr int kWarpsPerBlock = 8;
constexpr int kThreadsPerBlock = kWarpSize * kWarpsPerBlock;
constexpr int kMaxPointsPerBlock = 1024;  // 32 KB of points in shared memory
constexpr int kMinPointsPerWarp = 8;      // below this a block's set-up outweighs its work
constexpr std::size_t kMaxItems = std::size_t{1} << 24;  // points or particles per call

void check(cudaError_t status, const char* what) {
  if (status != cudaSuccess) {
    throw std::runtime_error(std::string("CUDA ") + what + " failed: " + cudaGetErrorString(status));
  }
}

// Device memory that only grows (no allocation per frame once the sizes have been seen).
class DeviceBuffer {
 public:
  DeviceBuffer() = default;
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  ~DeviceBuffer() {
    if (data_ != nullptr) cudaFree(data_);
  }
  // Returns true when it had to reallocate (the contents are then undefined).
  bool reserve(std::size_t bytes, cudaStream_t stream, const char* what) {
    if (bytes <= capacity_) return false;
    if (data_ != nullptr) {
      check(cudaStreamSynchronize(stream), what);  // work in flight may still read the old buffer
      check(cudaFree(data_), what);
      data_ = nullptr;
      capacity_ = 0;
    }
    const std::size_t grown = bytes + bytes / 4;
    check(cudaMalloc(&data_, grown), what);
    capacity_ = grown;
    return true;
  }
  template <class T>
  T* as() const {
    return static_cast<T*>(data_);
  }

 private:
  void* data_ = nullptr;
  std::size_t capacity_ = 0;
};

// Page-locked host memory for the per-frame transfers, grown like DeviceBuffer.
class PinnedBuffer {
 public:
  PinnedBuffer() = default;
  PinnedBuffer(const PinnedBuffer&) = delete;
  PinnedBuffer& operator=(const PinnedBuffer&) = delete;
  ~PinnedBuffer() {
    if (data_ != nullptr) cudaFreeHost(data_);
  }
  void reserve(std::size_t bytes, cudaStream_t stream, const char* what) {
    if (bytes <= capacity_) return;
    if (data_ != nullptr) {
      check(cudaStreamSynchronize(stream), what);
      check(cudaFreeHost(data_), what);
      data_ = nullptr;
      capacity_ = 0;
    }
    const std::size_t grown = bytes + bytes / 4;
    check(cudaHostAlloc(&data_, grown, cudaHostAllocDefault), what);
    capacity_ = grown;
  }
  template <class T>
  T* as() const {
    return static_cast<T*>(data_);
  }

 private:
  void* data_ = nullptr;
  std::size_t capacity_ = 0;
};

struct GridView {
  const float4* pairs;  // 6 hue-pair grids of `corners` float4 each
  int corners;
  int dx;   // corners along x
  int dxy;  // corners in one z slice
  float max_x, max_y, max_z;  // largest valid cell index per axis (dims - 2)
};

__global__ void expand_grid_kernel(const float4* __restrict__ raw, float4* __restrict__ pairs,
                                   int corners) {
  const int s = blockIdx.x * blockDim.x + threadIdx.x;
  if (s >= corners) return;
  const float4 lo = raw[2 * s];
  const float4 hi = raw[2 * s + 1];
  const float bins[6] = {lo.x, lo.y, lo.z, lo.w, hi.x, hi.y};
#pragma unroll
  for (int b = 0; b < 6; ++b) {
    pairs[b * corners + s] = make_float4(bins[b], bins[(b + 1) % 6], hi.z, hi.w);
  }
}

__device__ __forceinline__ float correlate(const float4 corner, const float4 h) {
  return fmaf(corner.x, h.x, fmaf(corner.y, h.y, fmaf(corner.z, h.z, corner.w * h.w)));
}

__device__ __forceinline__ float lerp(float a, float b, float t) { return fmaf(t, b - a, a); }

__global__ void __launch_bounds__(kThreadsPerBlock)
    score_kernel(GridView grid, const float4* __restrict__ points, int num_points,
                 int points_per_block, const float4* __restrict__ particles, int num_particles,
                 float* __restrict__ partials, unsigned* __restrict__ group_done,
                 float* __restrict__ scores) {
  extern __shared__ float4 shared_points[];  // two float4 per point: (x, y, z, hue_bin), weights
  __shared__ float warp_sums[kWarpsPerBlock][kWarpSize];

  const int lane = static_cast<int>(threadIdx.x) % kWarpSize;
  const int warp = static_cast<int>(threadIdx.x) / kWarpSize;
  const int group = static_cast<int>(blockIdx.x);
  const int split = static_cast<int>(blockIdx.y);
  const int first = split * points_per_block;
  const int count = min(points_per_block, num_points - first);

  for (int i = static_cast<int>(threadIdx.x); i < 2 * count; i += kThreadsPerBlock) {
    shared_points[i] = points[2 * first + i];
  }
  const int particle = group * kWarpSize + lane;
  const int p = min(particle, num_particles - 1);  // surplus lanes repeat the last particle
  const float4 r0 = particles[3 * p];
  const float4 r1 = particles[3 * p + 1];
  const float4 r2 = particles[3 * p + 2];
  __syncthreads();

  float sum = 0.f;
#pragma unroll 2
  for (int i = warp; i < count; i += kWarpsPerBlock) {
    const float4 z = shared_points[2 * i];
    const float4 h = shared_points[2 * i + 1];
    const float ux = fmaf(r0.x, z.x, fmaf(r0.y, z.y, fmaf(r0.z, z.z, r0.w)));
    const float uy = fmaf(r1.x, z.x, fmaf(r1.y, z.y, fmaf(r1.z, z.z, r1.w)));
    const float uz = fmaf(r2.x, z.x, fmaf(r2.y, z.y, fmaf(r2.z, z.z, r2.w)));
    const float fx = floorf(ux);
    const float fy = floorf(uy);
    const float fz = floorf(uz);
    // False for NaN too: such points, like those outside the grid, score 0.
    const bool inside = fx >= 0.f && fx <= grid.max_x && fy >= 0.f && fy <= grid.max_y &&
                        fz >= 0.f && fz <= grid.max_z;
    const int cell = inside ? (__float2int_rz(fz) * grid.dxy + __float2int_rz(fy) * grid.dx +
                               __float2int_rz(fx))
                            : 0;
    const float4* c = grid.pairs + (__float_as_int(z.w) * grid.corners + cell);
    const float4 c000 = __ldg(c);
    const float4 c100 = __ldg(c + 1);
    const float4 c010 = __ldg(c + grid.dx);
    const float4 c110 = __ldg(c + grid.dx + 1);
    const float4 c001 = __ldg(c + grid.dxy);
    const float4 c101 = __ldg(c + grid.dxy + 1);
    const float4 c011 = __ldg(c + grid.dxy + grid.dx);
    const float4 c111 = __ldg(c + grid.dxy + grid.dx + 1);
    const float tx = ux - fx;
    const float ty = uy - fy;
    const float tz = uz - fz;
    // 3.18 (trilinear weights, x then y then z) applied to the per-corner correlations of 3.19.
    const float y0 = lerp(lerp(correlate(c000, h), correlate(c100, h), tx),
                          lerp(correlate(c010, h), correlate(c110, h), tx), ty);
    const float y1 = lerp(lerp(correlate(c001, h), correlate(c101, h), tx),
                          lerp(correlate(c011, h), correlate(c111, h), tx), ty);
    sum += inside ? lerp(y0, y1, tz) : 0.f;
  }

  warp_sums[warp][lane] = sum;
  __syncthreads();
  if (warp != 0) return;
  float block_sum = 0.f;
#pragma unroll
  for (int w = 0; w < kWarpsPerBlock; ++w) block_sum += warp_sums[w][lane];
  if (gridDim.y == 1) {
    if (particle < num_particles) scores[particle] = block_sum;
    return;
  }
  if (particle < num_particles) partials[split * num_particles + particle] = block_sum;
  __threadfence();
  unsigned finished = 0;
  if (lane == 0) finished = atomicAdd(&group_done[group], 1u);
  finished = __shfl_sync(0xffffffffu, finished, 0);
  if (finished != gridDim.y - 1) return;
  // Last block of this group: every partial sum is in L2 (read past L1 with __ldcg).
  __threadfence();
  float total = 0.f;
  for (int s = 0; s < static_cast<int>(gridDim.y); ++s) total += __ldcg(&partials[s * num_particles + p]);
  if (particle < num_particles) scores[particle] = total;
  if (lane == 0) group_done[group] = 0u;  // ready for the next call
}

}  // namespace

int device_count(std::string* why) {
  int count = 0;
  const cudaError_t status = cudaGetDeviceCount(&count);
  if (status != cudaSuccess) {
    cudaGetLastError();  // clear the error so later calls start clean
    if (why != nullptr) *why = cudaGetErrorString(status);
    return -1;
  }
  return count;
}

std::string device_description(int device) {
  cudaDeviceProp props{};
  check(cudaGetDeviceProperties(&props, device), "cudaGetDeviceProperties");
  return std::string(props.name) + " (sm_" + std::to_string(props.major) + std::to_string(props.minor) +
         ", " + std::to_string(props.multiProcessorCount) + " SMs)";
}

struct JcsdDevice::State {
  DeviceOptions options;
  std::string description;
  int sm_count = 0;
  cudaStream_t stream = nullptr;
  cudaEvent_t grid_uploaded = nullptr;
  cudaEvent_t begin = nullptr;
  cudaEvent_t kernel_begin = nullptr;
  cudaEvent_t kernel_end = nullptr;
  cudaEvent_t end = nullptr;

  DeviceBuffer raw_grid, pairs, points, particles, partials, group_done, scores;
  PinnedBuffer grid_host, points_host, particles_host, scores_host;

  std::array<int, 3> dims{0, 0, 0};
  int corners = 0;
  bool counters_dirty = true;  // group_done needs zeroing (fresh buffer or an aborted kernel)
  DeviceTiming timing;

  void activate() const { check(cudaSetDevice(options.device), "cudaSetDevice"); }

  ~State() {
    if (stream != nullptr) cudaStreamSynchronize(stream);
    for (cudaEvent_t e : {grid_uploaded, begin, kernel_begin, kernel_end, end}) {
      if (e != nullptr) cudaEventDestroy(e);
    }
    if (stream != nullptr) cudaStreamDestroy(stream);
    // The buffers are freed by their destructors after this body; nothing is in flight now.
  }
};

JcsdDevice::JcsdDevice(const DeviceOptions& options) : state_(std::make_unique<State>()) {
  State& s = *state_;
  s.options = options;
  int count = 0;
  check(cudaGetDeviceCount(&count), "cudaGetDeviceCount");
  if (options.device < 0 || options.device >= count) {
    throw std::runtime_error("CUDA device " + std::to_string(options.device) + " requested, " +
                             std::to_string(count) + " present: " +
                             cudaGetErrorString(cudaErrorInvalidDevice));
  }
  check(cudaSetDevice(options.device), "cudaSetDevice");
  check(cudaDeviceGetAttribute(&s.sm_count, cudaDevAttrMultiProcessorCount, options.device),
        "cudaDeviceGetAttribute");
  s.description = device_description(options.device);
  check(cudaStreamCreateWithFlags(&s.stream, cudaStreamNonBlocking), "cudaStreamCreate");
  check(cudaEventCreateWithFlags(&s.grid_uploaded, cudaEventDisableTiming), "cudaEventCreate");
  for (cudaEvent_t* e : {&s.begin, &s.kernel_begin, &s.kernel_end, &s.end}) {
    check(cudaEventCreate(e), "cudaEventCreate");
  }
}

JcsdDevice::~JcsdDevice() {
  if (state_) cudaSetDevice(state_->options.device);
}

float* JcsdDevice::grid_staging(std::size_t corners) {
  State& s = *state_;
  s.activate();
  check(cudaEventSynchronize(s.grid_uploaded), "grid upload");
  s.grid_host.reserve(corners * 8 * sizeof(float), s.stream, "cudaHostAlloc (grid)");
  return s.grid_host.as<float>();
}

void JcsdDevice::upload_grid(const std::array<int, 3>& dims) {
  State& s = *state_;
  const std::size_t corners = static_cast<std::size_t>(dims[0]) * dims[1] * dims[2];
  if (dims[0] < 2 || dims[1] < 2 || dims[2] < 2 || corners * 6 > std::size_t{1} << 31) {
    throw std::runtime_error("JcsdDevice::upload_grid: dims must be >= 2 and the grid below 2^31 / 6 corners");
  }
  s.activate();
  s.corners = 0;  // no valid grid on the device until this upload is queued
  const int n = static_cast<int>(corners);
  s.raw_grid.reserve(corners * 8 * sizeof(float), s.stream, "cudaMalloc (grid)");
  s.pairs.reserve(corners * 6 * sizeof(float4), s.stream, "cudaMalloc (grid pairs)");
  check(cudaMemcpyAsync(s.raw_grid.as<float>(), s.grid_host.as<float>(), corners * 8 * sizeof(float),
                        cudaMemcpyHostToDevice, s.stream),
        "cudaMemcpyAsync (grid)");
  const int threads = 256;
  expand_grid_kernel<<<(n + threads - 1) / threads, threads, 0, s.stream>>>(
      s.raw_grid.as<float4>(), s.pairs.as<float4>(), n);
  check(cudaGetLastError(), "expand_grid_kernel launch");
  check(cudaEventRecord(s.grid_uploaded, s.stream), "cudaEventRecord");
  s.dims = dims;
  s.corners = n;
}

PointRecord* JcsdDevice::point_staging(std::size_t points) {
  State& s = *state_;
  if (points > kMaxItems) throw std::runtime_error("JcsdDevice: more than 2^24 points");
  s.activate();
  s.points_host.reserve(std::max<std::size_t>(points, 1) * sizeof(PointRecord), s.stream, "cudaHostAlloc (points)");
  return s.points_host.as<PointRecord>();
}

ParticleRecord* JcsdDevice::particle_staging(std::size_t particles) {
  State& s = *state_;
  if (particles > kMaxItems) throw std::runtime_error("JcsdDevice: more than 2^24 particles");
  s.activate();
  s.particles_host.reserve(std::max<std::size_t>(particles, 1) * sizeof(ParticleRecord), s.stream,
                           "cudaHostAlloc (particles)");
  return s.particles_host.as<ParticleRecord>();
}

void JcsdDevice::evaluate(std::size_t points, std::size_t particles, float* scores) {
  State& s = *state_;
  if (particles == 0) return;
  if (s.corners == 0) throw std::runtime_error("CUDA JCSD: no grid on the device (none uploaded, or the upload failed)");
  if (points == 0) {
    std::fill(scores, scores + particles, 0.f);
    return;
  }
  s.activate();
  const int num_points = static_cast<int>(points);
  const int num_particles = static_cast<int>(particles);

  // Launch shape: particle groups of one warp; the points of a group are split over enough
  // blocks to give every multiprocessor about blocks_per_sm blocks.
  const int groups = (num_particles + kWarpSize - 1) / kWarpSize;
  const int target_blocks = s.options.blocks_per_sm * s.sm_count;
  int splits = std::max(1, (target_blocks + groups - 1) / groups);
  splits = std::min(splits, std::max(1, num_points / (kWarpsPerBlock * kMinPointsPerWarp)));
  const int points_per_block = std::min((num_points + splits - 1) / splits, kMaxPointsPerBlock);
  splits = (num_points + points_per_block - 1) / points_per_block;
  if (static_cast<std::size_t>(splits) * particles > std::size_t{1} << 31) {
    throw std::runtime_error("JcsdDevice::evaluate: points x particles too large for one call");
  }

  s.points.reserve(points * sizeof(PointRecord), s.stream, "cudaMalloc (points)");
  s.particles.reserve(particles * sizeof(ParticleRecord), s.stream, "cudaMalloc (particles)");
  s.scores.reserve(particles * sizeof(float), s.stream, "cudaMalloc (scores)");
  s.scores_host.reserve(particles * sizeof(float), s.stream, "cudaHostAlloc (scores)");
  if (splits > 1) {
    s.partials.reserve(static_cast<std::size_t>(splits) * particles * sizeof(float), s.stream,
                       "cudaMalloc (partial sums)");
    if (s.group_done.reserve(static_cast<std::size_t>(groups) * sizeof(unsigned), s.stream,
                             "cudaMalloc (counters)")) {
      s.counters_dirty = true;
    }
    if (s.counters_dirty) {
      check(cudaMemsetAsync(s.group_done.as<unsigned>(), 0, static_cast<std::size_t>(groups) * sizeof(unsigned),
                            s.stream),
            "cudaMemsetAsync (counters)");
    }
  }

  s.counters_dirty = true;  // until this call has completed
  check(cudaEventRecord(s.begin, s.stream), "cudaEventRecord");
  check(cudaMemcpyAsync(s.points.as<void>(), s.points_host.as<void>(), points * sizeof(PointRecord),
                        cudaMemcpyHostToDevice, s.stream),
        "cudaMemcpyAsync (points)");
  check(cudaMemcpyAsync(s.particles.as<void>(), s.particles_host.as<void>(),
                        particles * sizeof(ParticleRecord), cudaMemcpyHostToDevice, s.stream),
        "cudaMemcpyAsync (particles)");
  const GridView grid{s.pairs.as<float4>(),
                      s.corners,
                      s.dims[0],
                      s.dims[0] * s.dims[1],
                      static_cast<float>(s.dims[0] - 2),
                      static_cast<float>(s.dims[1] - 2),
                      static_cast<float>(s.dims[2] - 2)};
  check(cudaEventRecord(s.kernel_begin, s.stream), "cudaEventRecord");
  score_kernel<<<dim3(static_cast<unsigned>(groups), static_cast<unsigned>(splits)), kThreadsPerBlock,
                 static_cast<std::size_t>(points_per_block) * 2 * sizeof(float4), s.stream>>>(
      grid, s.points.as<float4>(), num_points, points_per_block, s.particles.as<float4>(),
      num_particles, s.partials.as<float>(), s.group_done.as<unsigned>(), s.scores.as<float>());
  check(cudaGetLastError(), "score_kernel launch");
  check(cudaEventRecord(s.kernel_end, s.stream), "cudaEventRecord");
  check(cudaMemcpyAsync(s.scores_host.as<void>(), s.scores.as<void>(), particles * sizeof(float),
                        cudaMemcpyDeviceToHost, s.stream),
        "cudaMemcpyAsync (scores)");
  check(cudaEventRecord(s.end, s.stream), "cudaEventRecord");
  check(cudaStreamSynchronize(s.stream), "score_kernel");
  s.counters_dirty = false;
  std::memcpy(scores, s.scores_host.as<float>(), particles * sizeof(float));
  check(cudaEventElapsedTime(&s.timing.kernel_ms, s.kernel_begin, s.kernel_end), "cudaEventElapsedTime");
  check(cudaEventElapsedTime(&s.timing.transfer_ms, s.begin, s.end), "cudaEventElapsedTime");
}

DeviceTiming JcsdDevice::last_timing() const { return state_->timing; }

const std::string& JcsdDevice::description() const { return state_->description; }

}  // namespace mfot::cuda_detail
