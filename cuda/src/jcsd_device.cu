// CUDA JCSD hypothesis evaluation, thesis 3.3, equations 3.18 to 3.20 (the GPU side; the host
// side packs the data in cuda_jcsd_likelihood.cpp). Steps:
//  1. upload_grid: the model's J (8 floats per corner) goes to the device through pinned memory
//     and is laid out for the kernel (see GridView): with a 9-float corner stride and
//     bank-conflict-free padded strides when it fits in shared memory (objects up to ~30 cm at
//     15 mm on sm_90), else as six hue-pair float4 grids read through the read-only cache.
//  2. evaluate: points (32 B) and particles (48 B, the inverse pose already in grid units) go to
//     the device with one asynchronous copy each from pinned memory, on this object's stream.
//  3. the scoring kernel: work items are (32 particles, a chunk of points); a warp takes items
//     in turn, one particle per lane. All lanes read the same point (a broadcast load), so the
//     point's three non-zero SMR bins (3.19) are warp-uniform, and the particles of a filter lie
//     close together, so the 32 lanes read the 8 corners (3.18) of the same few cells. A block
//     of the shared-memory kernel copies the grid once and stays resident (one wave, items taken
//     in a loop). Each lane sums its particle's score in a register (3.20); the chunks of a
//     particle group write partial sums and the warp that finishes a group last (one integer
//     counter per group) adds them in chunk order. No floating-point atomics: scores are
//     deterministic.

#include "jcsd_device.cuh"

#include <cuda_runtime.h>

#include <algorithm>
#include <utility>
#include <cstring>
#include <stdexcept>
#include <string>

namespace mfot::cuda_detail {
namespace {

constexpr int kWarpSize = 32;
// Shared-grid blocks hold a whole multiprocessor's worth of warps, so each SM copies the grid
// once; global-grid blocks are smaller.
template <bool kShared>
constexpr int kWarpsPerBlock = kShared ? 32 : 16;
template <bool kShared>
constexpr int kThreadsPerBlock = kWarpSize * kWarpsPerBlock<kShared>;
template <bool kShared>
constexpr std::size_t kStageBytes = static_cast<std::size_t>(kWarpsPerBlock<kShared>) * 2 * kWarpSize * 16;
constexpr int kMinChunkPoints = 8;  // below this an item's set-up outweighs its work
constexpr int kMaxChunks = 64;      // partial sums per particle
constexpr std::size_t kMaxItems = std::size_t{1} << 24;  // points or particles per call

void check(cudaError_t status, const char* what) {
  if (status != cudaSuccess) {
    throw std::runtime_error(std::string("CUDA ") + what + " failed: " + cudaGetErrorString(status));
  }
}

// Strides (y, z) of the shared-memory layout, in corners: the smallest padding such that no two
// corners whose indices differ by at most 2 along every axis fall on the same bank (corner
// stride 9 floats, so corners c and c' share a bank exactly when c = c' mod 32).
std::pair<int, int> shared_strides(const std::array<int, 3>& dims) {
  const auto conflict_free = [](int sy, int sz) {
    for (int k = -2; k <= 2; ++k) {
      for (int j = -2; j <= 2; ++j) {
        for (int i = -2; i <= 2; ++i) {
          if ((i != 0 || j != 0 || k != 0) && (((i + j * sy + k * sz) % 32) + 32) % 32 == 0) return false;
        }
      }
    }
    return true;
  };
  for (int sy = dims[0]; sy < dims[0] + 32; ++sy) {
    for (int sz = sy * dims[1]; sz < sy * dims[1] + 32; ++sz) {
      if (conflict_free(sy, sz)) return {sy, sz};
    }
  }
  // Not reached: the 32 values of sy cover every residue mod 32, and several residues have one.
  return {dims[0], dims[0] * dims[1]};
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

// Two device layouts of J, both with padded strides (corner (x, y, z) at z * dxy + y * dx + x):
//  - global memory (grids too large for shared memory): six hue-pair grids of float4, grid b
//    holding (J(b), J((b + 1) % 6), J(6), J(7)) per corner, at b * plane + corner; one 16-byte
//    read-only-cache load per corner. dx = 2, dxy = 4 (mod 8) spreads a cell's corners over lines.
//  - shared memory: the 8 bins of a corner at corner * 9 + bin (a 9-float stride, so corners
//    land on distinct banks), three 4-byte loads per corner (the non-zero bins of the point's
//    SMR). dx and dxy are chosen so that no two corners within 2 cells of each other along every
//    axis share a bank: the lanes of a warp, whose particles lie close together, read their
//    corners without bank conflicts (or as broadcasts).
constexpr int kSharedCornerFloats = 9;

struct GridView {
  const float* data;  // the layout above, in global memory
  int plane;  // global layout: padded corners of one hue-pair grid; shared layout: float4 to copy
  int dx;     // padded stride of y
  int dxy;    // padded stride of z
  float max_x, max_y, max_z;  // largest valid cell index per axis (dims - 2)
};

struct Work {
  const float4* points;     // two float4 per point: (x, y, z, hue_bin bits), (w_lo, w_hi, w_dark, w_light)
  int num_points;
  int chunk_points;         // points per work item
  int chunks;               // work items per particle group
  const float4* particles;  // three float4 per particle: rows [A | b]
  int num_particles;
  float* partials;          // chunks x num_particles
  unsigned* group_done;     // one counter per particle group, zero between calls
  float* scores;
};

// One thread per padded corner: the corner's six hue-pair float4 (zeros in the padding).
__global__ void expand_pairs_kernel(const float4* __restrict__ raw, float4* __restrict__ pairs, int dim_x,
                                    int dim_y, int dx, int dxy, int plane) {
  const int index = blockIdx.x * blockDim.x + threadIdx.x;
  if (index >= plane) return;
  const int z = index / dxy;
  const int y = (index - z * dxy) / dx;
  const int x = index - z * dxy - y * dx;
  float4 lo = make_float4(0.f, 0.f, 0.f, 0.f);
  float4 hi = lo;
  if (x < dim_x && y < dim_y) {
    const int s = (z * dim_y + y) * dim_x + x;
    lo = raw[2 * s];
    hi = raw[2 * s + 1];
  }
  const float bins[6] = {lo.x, lo.y, lo.z, lo.w, hi.x, hi.y};
#pragma unroll
  for (int b = 0; b < 6; ++b) {
    pairs[b * plane + index] = make_float4(bins[b], bins[(b + 1) % 6], hi.z, hi.w);
  }
}

// One thread per float of the shared-memory layout (zeros in the padding).
__global__ void expand_shared_layout_kernel(const float* __restrict__ raw, float* __restrict__ out, int dim_x,
                                            int dim_y, int dx, int dxy, int total) {
  const int index = blockIdx.x * blockDim.x + threadIdx.x;
  if (index >= total) return;
  const int corner = index / kSharedCornerFloats;
  const int bin = index - corner * kSharedCornerFloats;
  const int z = corner / dxy;
  const int y = (corner - z * dxy) / dx;
  const int x = corner - z * dxy - y * dx;
  out[index] = (bin < 8 && x < dim_x && y < dim_y) ? raw[((z * dim_y + y) * dim_x + x) * 8 + bin] : 0.f;
}

__device__ __forceinline__ float correlate(const float4 corner, const float4 h) {
  return fmaf(corner.x, h.x, fmaf(corner.y, h.y, fmaf(corner.z, h.z, corner.w * h.w)));
}

__device__ __forceinline__ float lerp(float a, float b, float t) { return fmaf(t, b - a, a); }

// Sum of 3.19 over the points [first, last) for the particle whose rows are r0, r1, r2.
// Sum of 3.19 over the points [first, last) for the particle whose rows are r0, r1, r2. The
// points go through `stage` (this warp's 64 float4 of shared memory), 32 at a time, in one
// coalesced load, so the loop pays one memory latency per 32 points; every lane then reads the
// same point (a broadcast).
template <bool kShared>
__device__ __forceinline__ float score_points(const float* grid, const GridView& view,
                                              const float4* __restrict__ points, float4* stage, int first,
                                              int last, float4 r0, float4 r1, float4 r2) {
  const int lane = static_cast<int>(threadIdx.x) % kWarpSize;
  float sum = 0.f;
  for (int base = first; base < last; base += kWarpSize) {
    const int count = min(kWarpSize, last - base);
    __syncwarp();  // the previous batch has been read
    if (lane < count) {
      stage[2 * lane] = __ldg(points + 2 * (base + lane));
      stage[2 * lane + 1] = __ldg(points + 2 * (base + lane) + 1);
    }
    __syncwarp();
#pragma unroll 2
    for (int i = 0; i < count; ++i) {
      const float4 z = stage[2 * i];
      const float4 h = stage[2 * i + 1];
      const float ux = fmaf(r0.x, z.x, fmaf(r0.y, z.y, fmaf(r0.z, z.z, r0.w)));
      const float uy = fmaf(r1.x, z.x, fmaf(r1.y, z.y, fmaf(r1.z, z.z, r1.w)));
      const float uz = fmaf(r2.x, z.x, fmaf(r2.y, z.y, fmaf(r2.z, z.z, r2.w)));
      const float fx = floorf(ux);
      const float fy = floorf(uy);
      const float fz = floorf(uz);
      // False for NaN too: such points, like those outside the grid, score 0.
      const bool inside = fx >= 0.f && fx <= view.max_x && fy >= 0.f && fy <= view.max_y &&
                          fz >= 0.f && fz <= view.max_z;
      const int cell = inside ? (__float2int_rz(fz) * view.dxy + __float2int_rz(fy) * view.dx +
                                 __float2int_rz(fx))
                              : 0;
      const int hue_bin = __float_as_int(z.w);
      // 3.19 at the 8 corners of the cell: d[corner], corner bits (x, y, z) from the lowest.
      float d[8];
      if constexpr (kShared) {
        // The point's three non-zero bins (warp-uniform): hue_bin, hue_bin + 1 and one achromatic.
        const int bin_hi = hue_bin == 5 ? 0 : hue_bin + 1;
        const int bin_gray = h.w > 0.f ? 7 : 6;
        const float w_gray = h.z + h.w;  // one of the two is 0
        const float* base = grid + cell * kSharedCornerFloats;
#pragma unroll
        for (int k = 0; k < 8; ++k) {
          const float* corner =
              base + ((k & 1) + ((k >> 1) & 1) * view.dx + (k >> 2) * view.dxy) * kSharedCornerFloats;
          d[k] = fmaf(h.x, corner[hue_bin], fmaf(h.y, corner[bin_hi], w_gray * corner[bin_gray]));
        }
      } else {
        const float4* base = reinterpret_cast<const float4*>(grid) + hue_bin * view.plane + cell;
#pragma unroll
        for (int k = 0; k < 8; ++k) {
          d[k] = correlate(__ldg(base + (k & 1) + ((k >> 1) & 1) * view.dx + (k >> 2) * view.dxy), h);
        }
      }
      const float tx = ux - fx;
      const float ty = uy - fy;
      const float tz = uz - fz;
      // 3.18: trilinear weights, x then y then z.
      const float y0 = lerp(lerp(d[0], d[1], tx), lerp(d[2], d[3], tx), ty);
      const float y1 = lerp(lerp(d[4], d[5], tx), lerp(d[6], d[7], tx), ty);
      sum += inside ? lerp(y0, y1, tz) : 0.f;
    }
  }
  return sum;
}

template <bool kShared>
__global__ void __launch_bounds__(kThreadsPerBlock<kShared>)
    score_kernel(GridView view, Work work) {
  constexpr int kThreads = kThreadsPerBlock<kShared>;
  constexpr int kWarps = kWarpsPerBlock<kShared>;
  // Dynamic shared memory: 64 float4 of point stage per warp, then (kShared) the grid.
  extern __shared__ float4 shared_memory[];
  float4* stage = shared_memory + (threadIdx.x / kWarpSize) * 2 * kWarpSize;
  float4* shared_grid = shared_memory + kWarps * 2 * kWarpSize;
  const float* grid = view.data;
  if constexpr (kShared) {
    // view.plane float4 to copy; four independent loads in flight per thread before their stores.
    const float4* source = reinterpret_cast<const float4*>(view.data);
    const int total = view.plane;
    for (int base = static_cast<int>(threadIdx.x); base < total; base += 4 * kThreads) {
      float4 v[4];
#pragma unroll
      for (int k = 0; k < 4; ++k) {
        const int i = base + k * kThreads;
        if (i < total) v[k] = __ldg(source + i);
      }
#pragma unroll
      for (int k = 0; k < 4; ++k) {
        const int i = base + k * kThreads;
        if (i < total) shared_grid[i] = v[k];
      }
    }
    __syncthreads();
    grid = reinterpret_cast<const float*>(shared_grid);
  }
  const int lane = static_cast<int>(threadIdx.x) % kWarpSize;
  const int items = ((work.num_particles + kWarpSize - 1) / kWarpSize) * work.chunks;
  const int stride = static_cast<int>(gridDim.x) * kWarps;
  for (int item = static_cast<int>(blockIdx.x) * kWarps + static_cast<int>(threadIdx.x) / kWarpSize;
       item < items; item += stride) {
    const int group = item / work.chunks;
    const int chunk = item - group * work.chunks;
    const int particle = group * kWarpSize + lane;
    const int p = min(particle, work.num_particles - 1);  // surplus lanes repeat the last particle
    const float4 r0 = __ldg(work.particles + 3 * p);
    const float4 r1 = __ldg(work.particles + 3 * p + 1);
    const float4 r2 = __ldg(work.particles + 3 * p + 2);
    const int first = chunk * work.chunk_points;
    const int last = min(first + work.chunk_points, work.num_points);
    const float sum = score_points<kShared>(grid, view, work.points, stage, first, last, r0, r1, r2);
    if (work.chunks == 1) {
      if (particle < work.num_particles) work.scores[particle] = sum;
      continue;
    }
    if (particle < work.num_particles) work.partials[chunk * work.num_particles + particle] = sum;
    __threadfence();  // each lane's partial sum is visible device-wide ...
    __syncwarp();     // ... before lane 0 counts the chunk as done
    unsigned done = 0;
    if (lane == 0) done = atomicAdd(&work.group_done[group], 1u);
    done = __shfl_sync(0xffffffffu, done, 0);
    if (done != static_cast<unsigned>(work.chunks - 1)) continue;
    // Last chunk of this group: every partial sum is in L2 (read past L1 with __ldcg).
    __threadfence();
    float total = 0.f;
#pragma unroll 8
    for (int k = 0; k < work.chunks; ++k) total += __ldcg(work.partials + k * work.num_particles + p);
    if (particle < work.num_particles) work.scores[particle] = total;
    if (lane == 0) work.group_done[group] = 0u;  // ready for the next call
  }
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

  DeviceBuffer raw_grid, layout, points, particles, partials, group_done, scores;
  PinnedBuffer grid_host, points_host, particles_host, scores_host;

  std::array<int, 3> dims{0, 0, 0};
  int corners = 0;  // 0: no valid grid on the device
  int stride_y = 0, stride_z = 0, plane = 0;  // the layout in use (GridView)
  std::array<int, 3> strides_for{0, 0, 0};    // dims whose shared-layout strides are cached
  std::pair<int, int> shared_strides{0, 0};
  int max_shared_bytes = 0;   // dynamic shared memory a block may opt in to
  bool grid_in_shared = false;  // the current grid's hue-pair grids fit in shared memory
  int resident_warps = 0;       // warps of the chosen kernel that run at once on the device
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
  check(cudaDeviceGetAttribute(&s.max_shared_bytes, cudaDevAttrMaxSharedMemoryPerBlockOptin, options.device),
        "cudaDeviceGetAttribute");
  check(cudaFuncSetAttribute(score_kernel<true>, cudaFuncAttributeMaxDynamicSharedMemorySize, s.max_shared_bytes),
        "cudaFuncSetAttribute");
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
  s.raw_grid.reserve(corners * 8 * sizeof(float), s.stream, "cudaMalloc (grid)");
  check(cudaMemcpyAsync(s.raw_grid.as<float>(), s.grid_host.as<float>(), corners * 8 * sizeof(float),
                        cudaMemcpyHostToDevice, s.stream),
        "cudaMemcpyAsync (grid)");
  const int threads = 256;

  // Shared-memory layout when it fits and a block of the shared kernel can be resident.
  if (dims != s.strides_for) {  // the search costs microseconds; models keep their size for long
    s.shared_strides = shared_strides(dims);
    s.strides_for = dims;
  }
  const auto [shared_y, shared_z] = s.shared_strides;
  const std::size_t shared_floats = static_cast<std::size_t>(shared_z) * dims[2] * kSharedCornerFloats;
  const std::size_t shared_float4s = (shared_floats + 3) / 4;
  const std::size_t shared_bytes = shared_float4s * sizeof(float4);
  int blocks_per_sm = 0;
  if (shared_bytes + kStageBytes<true> <= static_cast<std::size_t>(s.max_shared_bytes)) {
    check(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&blocks_per_sm, score_kernel<true>,
                                                        kThreadsPerBlock<true>, shared_bytes + kStageBytes<true>),
          "cudaOccupancyMaxActiveBlocksPerMultiprocessor");
  }
  s.grid_in_shared = blocks_per_sm > 0;
  if (s.grid_in_shared) {
    s.layout.reserve(shared_bytes, s.stream, "cudaMalloc (grid layout)");
    const int total = static_cast<int>(shared_float4s * 4);
    expand_shared_layout_kernel<<<(total + threads - 1) / threads, threads, 0, s.stream>>>(
        s.raw_grid.as<float>(), s.layout.as<float>(), dims[0], dims[1], shared_y, shared_z, total);
    check(cudaGetLastError(), "expand_shared_layout_kernel launch");
    s.stride_y = shared_y;
    s.stride_z = shared_z;
    s.plane = static_cast<int>(shared_float4s);
  } else {
    // Hue-pair layout: y stride = 2 and z stride = 4 (mod 8).
    const int stride_y = dims[0] + ((2 - dims[0]) % 8 + 8) % 8;
    const int stride_z = stride_y * dims[1] + ((4 - stride_y * dims[1]) % 8 + 8) % 8;
    const std::size_t plane = static_cast<std::size_t>(stride_z) * dims[2];
    if (plane * 6 >= std::size_t{1} << 31) throw std::runtime_error("JcsdDevice::upload_grid: grid too large");
    s.layout.reserve(plane * 6 * sizeof(float4), s.stream, "cudaMalloc (grid layout)");
    const int padded = static_cast<int>(plane);
    expand_pairs_kernel<<<(padded + threads - 1) / threads, threads, 0, s.stream>>>(
        s.raw_grid.as<float4>(), s.layout.as<float4>(), dims[0], dims[1], stride_y, stride_z, padded);
    check(cudaGetLastError(), "expand_pairs_kernel launch");
    check(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&blocks_per_sm, score_kernel<false>,
                                                        kThreadsPerBlock<false>, kStageBytes<false>),
          "cudaOccupancyMaxActiveBlocksPerMultiprocessor");
    s.stride_y = stride_y;
    s.stride_z = stride_z;
    s.plane = padded;
  }
  check(cudaEventRecord(s.grid_uploaded, s.stream), "cudaEventRecord");
  s.resident_warps = std::max(1, blocks_per_sm) * s.sm_count * (s.grid_in_shared ? kWarpsPerBlock<true> : kWarpsPerBlock<false>);
  s.dims = dims;
  s.corners = static_cast<int>(corners);
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

  // Launch shape: work items of (32 particles, a chunk of points), about items_per_warp per
  // resident warp, chunks of at least kMinChunkPoints points and at most kMaxChunks per group
  // (the last warp of a group adds the partial sums, so that sum stays short).
  const int groups = (num_particles + kWarpSize - 1) / kWarpSize;
  const int target_items = s.options.items_per_warp * s.resident_warps;
  int chunks = std::max(1, (target_items + groups - 1) / groups);
  chunks = std::min({chunks, kMaxChunks, std::max(1, num_points / kMinChunkPoints)});
  const int chunk_points = (num_points + chunks - 1) / chunks;
  chunks = (num_points + chunk_points - 1) / chunk_points;
  const int items = groups * chunks;
  const int warps_per_block = s.grid_in_shared ? kWarpsPerBlock<true> : kWarpsPerBlock<false>;
  const int blocks = (std::min(s.resident_warps, items) + warps_per_block - 1) / warps_per_block;
  const std::size_t shared_bytes = s.grid_in_shared ? kStageBytes<true> + static_cast<std::size_t>(s.plane) * sizeof(float4)
                                                    : kStageBytes<false>;

  s.points.reserve(points * sizeof(PointRecord), s.stream, "cudaMalloc (points)");
  s.particles.reserve(particles * sizeof(ParticleRecord), s.stream, "cudaMalloc (particles)");
  s.scores.reserve(particles * sizeof(float), s.stream, "cudaMalloc (scores)");
  s.scores_host.reserve(particles * sizeof(float), s.stream, "cudaHostAlloc (scores)");
  if (chunks > 1) {
    s.partials.reserve(static_cast<std::size_t>(chunks) * particles * sizeof(float), s.stream,
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
  const GridView view{s.layout.as<float>(),
                      s.plane,
                      s.stride_y,
                      s.stride_z,
                      static_cast<float>(s.dims[0] - 2),
                      static_cast<float>(s.dims[1] - 2),
                      static_cast<float>(s.dims[2] - 2)};
  const Work work{s.points.as<float4>(),      num_points,           chunk_points,
                  chunks,                     s.particles.as<float4>(), num_particles,
                  s.partials.as<float>(),     s.group_done.as<unsigned>(), s.scores.as<float>()};
  check(cudaEventRecord(s.kernel_begin, s.stream), "cudaEventRecord");
  if (s.grid_in_shared) {
    score_kernel<true><<<blocks, kThreadsPerBlock<true>, shared_bytes, s.stream>>>(view, work);
  } else {
    score_kernel<false><<<blocks, kThreadsPerBlock<false>, shared_bytes, s.stream>>>(view, work);
  }
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
