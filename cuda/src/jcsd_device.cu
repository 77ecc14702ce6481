// CUDA JCSD hypothesis evaluation, thesis 3.3, equations 3.18 to 3.20 (the GPU side; the host
// side packs the data in cuda_jcsd_likelihood.cpp). Steps:
//  1. upload_grid: the model's J (8 floats per corner) goes to the device through pinned memory.
//     The kernel reads it as 16-bit floats (J times a power of two, so that no value overflows
//     and none that matters is subnormal) in planes with padded strides (GridLayout): 6 hue
//     planes whose element holds hue bins b and (b + 1) % 6 of a corner and of its x neighbour
//     (8 bytes), and 2 achromatic planes whose element holds one bin of a corner and of its x
//     neighbour (4 bytes). One point's three non-zero SMR bins (3.19) at the 8 corners of its
//     cell are 8 loads, 48 bytes. The planes are expanded once per upload, into global memory;
//     each block copies them as they are into shared memory when they fit there (16-byte
//     asynchronous copies, no per-block index arithmetic), larger grids are read through the
//     read-only cache.
//  2. evaluate: points (32 B) and particles (48 B, the inverse pose already in grid units) go to
//     the device in one asynchronous copy from pinned memory, on this object's stream.
//  3. the scoring kernel: one resident block of 512 threads per multiprocessor takes work items
//     (a tile of 16 particles, a split of the points) in turn. The 16 lanes of each half warp
//     hold the tile's particles and read the same point, 32 points per pass of the block.
//     3.19 is evaluated in 16-bit arithmetic for a corner and its x neighbour at once, the
//     interpolation (3.18) and the sums (3.20) in float: every term is non-negative, so the
//     scores differ from the CPU's by a bounded relative amount (kCudaJcsdRelativeError).
//     Shared memory serves 8-byte loads per half warp, and since a filter's particles lie close
//     together the half warp looks up the same or adjacent cells, which the padded strides put
//     on distinct banks: broadcasts without bank conflicts in the common case. Each thread keeps
//     its next point in registers while it scores the current one, two passes unrolled. The block adds its threads'
//     sums in a fixed order (shuffles, shared memory); with several splits per tile the block
//     that finishes a tile last (one integer counter per tile) adds the splits' sums in split
//     order. No floating-point atomics: scores are bit-identical from call to call. Splits are
//     chosen per call so that the items spread evenly over the multiprocessors.

#include <cuda_fp16.h>
#include <cuda_pipeline.h>
#include <cuda_runtime.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "jcsd_device.cuh"

namespace mfot::cuda_detail {
namespace {

constexpr int kWarpSize = 32;
// 512 threads of about 104 registers (two points in flight per thread) measured 3 % faster on
// the H100 than 1024 threads of 64 registers (one point).
constexpr int kThreadsPerBlock = 512;
constexpr int kWarpsPerBlock = kThreadsPerBlock / kWarpSize;
constexpr int kBins = 8;
// Planes of 16-bit floats (J scaled by GridLayout::scale): 6 hue planes, whose element for hue
// bin b holds bins b and (b + 1) % 6 (3.19) of a corner and of its x neighbour (8 bytes, one
// load), then 2 achromatic planes (bins 6 and 7) whose element holds the bin of a corner and of
// its x neighbour (4 bytes).
constexpr int kHuePlanes = 6;
constexpr int kGrayPlanes = 2;
using HueElement = uint2;      // __half2 (b at x, x + 1), __half2 (b + 1 at x, x + 1)
using GrayElement = unsigned;  // __half2 (g at x, x + 1)
constexpr int kCornerBytes = kHuePlanes * sizeof(HueElement) + kGrayPlanes * sizeof(GrayElement);
// The scaled grid's largest value is below 2^kScaleExponent: far from the 16-bit float's
// largest finite value (65504) for the weighted sums of 3.19 (weights in [0, 1]), and with
// subnormals only below 2^-24 of it.
constexpr int kScaleExponent = 14;
// Particles per tile: a half warp, whose lanes read one point (shared-memory loads of 8 bytes
// are served per half warp).
constexpr int kTile = 16;
constexpr int kPointsPerPass = kThreadsPerBlock / kTile;                      // points a block scores at once
constexpr std::size_t kReduceBytes = kWarpsPerBlock * kTile * sizeof(float);  // one sum per warp and particle
constexpr int kMaxSplits = 64;                                                // split sums per particle
constexpr int kMinSplitPoints = kPointsPerPass;                               // fewer would leave threads idle
constexpr std::size_t kMaxItems = std::size_t{1} << 24;                       // points or particles per call
// Device frame padding: a thread's prefetch reads up to kPointsPerPass points past the last one.
constexpr std::size_t kFramePadBytes = kPointsPerPass * sizeof(PointRecord);

void check(cudaError_t status, const char* what) {
  if (status != cudaSuccess) {
    throw std::runtime_error(std::string("CUDA ") + what + " failed: " + cudaGetErrorString(status));
  }
}

// Padded strides (y, z) of the planes, in corners. A hue element (8 bytes) spans 2 of the 32
// banks, so elements e and e' share banks exactly when e = e' (mod 16); a gray element (4 bytes)
// when e = e' (mod 32), implied. The strides put every corner and its 26 neighbours on different
// banks: lanes whose particles put a point in adjacent cells read without conflicts.
std::pair<int, int> padded_strides(const std::array<int, 3>& dims) {
  const auto conflict_free = [](int sy, int sz) {
    for (int k = -1; k <= 1; ++k) {
      for (int j = -1; j <= 1; ++j) {
        for (int i = -1; i <= 1; ++i) {
          if ((i != 0 || j != 0 || k != 0) && (((i + j * sy + k * sz) % 16) + 16) % 16 == 0) return false;
        }
      }
    }
    return true;
  };
  for (int sy = dims[0]; sy < dims[0] + 16; ++sy) {
    for (int sz = sy * dims[1]; sz < sy * dims[1] + 16; ++sz) {
      if (conflict_free(sy, sz)) return {sy, sz};
    }
  }
  // Not reached: some sy is 3 (mod 16), and then some sz is 9 (mod 16).
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

// J as the planes above, element of corner (x, y, z) at z * stride_z + y * stride_y + x of its
// plane (zeros in the padding): the 6 hue planes, then the 2 gray planes. In shared memory the
// reduction buffer follows the planes.
struct GridLayout {
  const float4* raw;     // compact J: corner s (x fastest) at raw[2 s] (bins 0-3) and raw[2 s + 1] (bins 4-7)
  const float4* planes;  // the planes in global memory, expanded at upload_grid
  float scale;           // a power of two: the planes hold J * scale
  float inv_scale;       // 1 / scale
  int dim_x, dim_y;
  int stride_y, stride_z;          // padded strides in corners
  int plane;                       // elements per plane: stride_z * dims[2]
  int bytes_y, bytes_z, bytes_yz;  // the strides y, z and y + z in bytes of a hue plane (half in a gray plane)
  unsigned max_x, max_y, max_z;    // largest valid cell index per axis (dims - 2)
};

struct Frame {
  const float4* points;  // two float4 per point: (x, y, z, hue plane bits), (w_lo, w_hi, w_gray as __half2 (w, w) bits,
                         // gray plane bits)
  int num_points;
  const float4* particles;  // three float4 per particle: rows [A | b]
  int num_particles;
  int splits;           // work items per tile
  int split_points;     // points per split
  float* partials;      // splits x (tiles * kTile) split sums (splits > 1)
  unsigned* tile_done;  // splits done per tile, zero between calls (splits > 1)
  float* scores;
};

GridLayout make_layout(const float4* raw, const float4* planes, float scale, const std::array<int, 3>& dims,
                       int stride_y, int stride_z, int plane) {
  constexpr int element = sizeof(HueElement);
  return {raw,
          planes,
          scale,
          1.f / scale,
          dims[0],
          dims[1],
          stride_y,
          stride_z,
          plane,
          stride_y * element,
          stride_z * element,
          (stride_y + stride_z) * element,
          static_cast<unsigned>(dims[0] - 2),
          static_cast<unsigned>(dims[1] - 2),
          static_cast<unsigned>(dims[2] - 2)};
}

// Bytes of the planes of `plane` elements each.
__host__ __device__ constexpr long long plane_bytes(int plane) { return static_cast<long long>(plane) * kCornerBytes; }

// 16-byte words holding the planes (the last one zero-padded).
__host__ __device__ constexpr int plane_words(int plane) {
  return static_cast<int>((plane_bytes(plane) + sizeof(float4) - 1) / sizeof(float4));
}

// (a, b) as the bits of a __half2, rounded to nearest.
__host__ __device__ inline unsigned half2_bits(float a, float b) {
  const __half_raw lo = __float2half_rn(a);
  const __half_raw hi = __float2half_rn(b);
  return static_cast<unsigned>(lo.x) | (static_cast<unsigned>(hi.x) << 16);
}

// Writes padded corner c of the planes from the compact grid.
__device__ __forceinline__ void expand_corner(const GridLayout& layout, int c, unsigned char* planes) {
  const int z = c / layout.stride_z;
  const int rest = c - z * layout.stride_z;
  const int y = rest / layout.stride_y;
  const int x = rest - y * layout.stride_y;
  const float4 zero = make_float4(0.f, 0.f, 0.f, 0.f);
  float4 lo0 = zero, hi0 = zero, lo1 = zero, hi1 = zero;  // bins 0-3 and 4-7 at x and x + 1
  if (x < layout.dim_x && y < layout.dim_y) {
    const int s = (z * layout.dim_y + y) * layout.dim_x + x;
    lo0 = __ldg(layout.raw + 2 * s);
    hi0 = __ldg(layout.raw + 2 * s + 1);
    if (x + 1 < layout.dim_x) {
      lo1 = __ldg(layout.raw + 2 * s + 2);
      hi1 = __ldg(layout.raw + 2 * s + 3);
    }
  }
  const float here[kBins] = {lo0.x, lo0.y, lo0.z, lo0.w, hi0.x, hi0.y, hi0.z, hi0.w};
  const float next[kBins] = {lo1.x, lo1.y, lo1.z, lo1.w, hi1.x, hi1.y, hi1.z, hi1.w};
  const auto pack = [&](int bin) { return half2_bits(here[bin] * layout.scale, next[bin] * layout.scale); };
  auto* hue = reinterpret_cast<HueElement*>(planes);
#pragma unroll
  for (int b = 0; b < kHuePlanes; ++b) hue[b * layout.plane + c] = make_uint2(pack(b), pack((b + 1) % kHuePlanes));
  auto* gray = reinterpret_cast<GrayElement*>(hue + kHuePlanes * layout.plane);
#pragma unroll
  for (int g = 0; g < kGrayPlanes; ++g) gray[g * layout.plane + c] = pack(kHuePlanes + g);
}

// One thread per padded corner: the planes in global memory (once per upload_grid).
__global__ void expand_planes_kernel(GridLayout layout, unsigned char* planes) {
  const int c = static_cast<int>(blockIdx.x * blockDim.x + threadIdx.x);
  if (c < layout.plane) expand_corner(layout, c, planes);
}

__device__ __forceinline__ float lerp(float a, float b, float t) { return fmaf(t, b - a, a); }

template <bool kShared, class T>
__device__ __forceinline__ T load(const char* p) {
  if constexpr (kShared) {
    return *reinterpret_cast<const T*>(p);
  } else {
    return __ldg(reinterpret_cast<const T*>(p));
  }
}

__device__ __forceinline__ __half2 as_half2(unsigned bits) {
  __half2 h;
  memcpy(&h, &bits, sizeof h);
  return h;
}

// Bias that makes a float add round to an integer: for |u| < 2^22, u + kFloorBias rounded down
// is floor(u) + kFloorBias exactly, with floor(u) in the low mantissa bits. This replaces the
// floor and float-to-int conversions (quarter-rate instructions) by full-rate adds.
constexpr float kFloorBias = 12582912.f;  // 1.5 * 2^23
constexpr int kFloorBiasBits = 0x4B400000;

// 3.18 with 3.19 for one point (a, b as in Frame::points) and the particle whose rows are r0, r1,
// r2; 0 for points outside the grid. A coordinate beyond +-2^22 cells, infinite or NaN gives an
// index outside [0, max] (the biased bits differ from kFloorBiasBits by at least 2^22), so such
// points score 0 as on the CPU.
template <bool kShared>
__device__ __forceinline__ float point_score(const char* planes, const GridLayout& layout, const float4& r0,
                                             const float4& r1, const float4& r2, const float4& a, const float4& b) {
  const float ux = fmaf(r0.x, a.x, fmaf(r0.y, a.y, fmaf(r0.z, a.z, r0.w)));
  const float uy = fmaf(r1.x, a.x, fmaf(r1.y, a.y, fmaf(r1.z, a.z, r1.w)));
  const float uz = fmaf(r2.x, a.x, fmaf(r2.y, a.y, fmaf(r2.z, a.z, r2.w)));
  const float bx = __fadd_rd(ux, kFloorBias);
  const float by = __fadd_rd(uy, kFloorBias);
  const float bz = __fadd_rd(uz, kFloorBias);
  const unsigned ix = static_cast<unsigned>(__float_as_int(bx) - kFloorBiasBits);
  const unsigned iy = static_cast<unsigned>(__float_as_int(by) - kFloorBiasBits);
  const unsigned iz = static_cast<unsigned>(__float_as_int(bz) - kFloorBiasBits);
  const bool inside = ix <= layout.max_x && iy <= layout.max_y && iz <= layout.max_z;
  const int cell = inside ? static_cast<int>(iz) * layout.bytes_z + static_cast<int>(iy) * layout.bytes_y +
                                static_cast<int>(ix) * static_cast<int>(sizeof(HueElement))
                          : 0;
  // The point's three non-zero bins (a.w, b.w hold their planes' byte offsets): hue_bin and the
  // next hue bin (one hue element), and one achromatic bin.
  const char* hue = planes + __float_as_int(a.w) + cell;
  const char* gray = planes + __float_as_int(b.w) + (cell >> 1);
  const float tx = ux - (bx - kFloorBias);
  // 3.19 at the corners x and x + 1 of one (y, z) edge of the cell, interpolated along x.
  const auto edge = [&](int offset) {
    const uint2 lh = load<kShared, uint2>(hue + offset);
    const __half2 g = as_half2(load<kShared, unsigned>(gray + (offset >> 1)));
    // 3.19 in 16-bit arithmetic for both corners at once (b.x, b.y, b.z hold the weights as
    // __half2 (w, w)): every term is non-negative, so each rounding stays relative.
    __half2 t = __hmul2(as_half2(__float_as_uint(b.z)), g);
    t = __hfma2(as_half2(__float_as_uint(b.y)), as_half2(lh.y), t);
    t = __hfma2(as_half2(__float_as_uint(b.x)), as_half2(lh.x), t);
    const float2 d = __half22float2(t);
    return lerp(d.x, d.y, tx);
  };
  const float e00 = edge(0);
  const float e10 = edge(layout.bytes_y);
  const float e01 = edge(layout.bytes_z);
  const float e11 = edge(layout.bytes_yz);
  const float ty = uy - (by - kFloorBias);
  const float score = lerp(lerp(e00, e10, ty), lerp(e01, e11, ty), uz - (bz - kFloorBias));
  return inside ? score : 0.f;
}

template <bool kShared>
__global__ void __launch_bounds__(kThreadsPerBlock, 1) score_kernel(GridLayout layout, Frame frame) {
  extern __shared__ float4 shared_memory[];
  const int thread = static_cast<int>(threadIdx.x);
  const int lane = thread % kWarpSize;
  const int warp = thread / kWarpSize;
  const int member = thread % kTile;  // this thread's particle in the tile
  const int slot = thread / kTile;    // this thread's point in each pass over kPointsPerPass points
  const int tiles = (frame.num_particles + kTile - 1) / kTile;
  const int items = tiles * frame.splits;
  const int padded_particles = tiles * kTile;
  // Points are prefetched without bounds checks: the device frame is padded (kFramePadBytes)
  // and what is read past a split's end is never used.
  const float4* points = frame.points;

  // An item's particle rows and this thread's first point, loaded ahead of their use (the
  // first item's before the grid is staged, the next item's during the reduction).
  float4 r0, r1, r2, a, b;
  const auto prefetch = [&](int item) {
    const int tile = item / frame.splits;
    const int p = min(tile * kTile + member, frame.num_particles - 1);  // surplus lanes repeat the last
    r0 = __ldg(frame.particles + 3 * p);
    r1 = __ldg(frame.particles + 3 * p + 1);
    r2 = __ldg(frame.particles + 3 * p + 2);
    // Clamped: an empty split may start past the end.
    const int first = min((item - tile * frame.splits) * frame.split_points + slot, frame.num_points - 1);
    a = __ldg(points + 2 * first);
    b = __ldg(points + 2 * first + 1);
  };
  int item = static_cast<int>(blockIdx.x);
  prefetch(item);

  const char* planes = reinterpret_cast<const char*>(layout.planes);
  float* reduce = reinterpret_cast<float*>(shared_memory);
  if constexpr (kShared) {
    // The planes, expanded once at upload, are copied as they are (16-byte asynchronous copies
    // that bypass the registers); the reduction buffer follows them.
    const int words = plane_words(layout.plane);
    const auto* source = reinterpret_cast<const float4*>(layout.planes);
    for (int w = thread; w < words; w += kThreadsPerBlock) {
      __pipeline_memcpy_async(shared_memory + w, source + w, sizeof(float4));
    }
    __pipeline_commit();
    __pipeline_wait_prior(0);
    planes = reinterpret_cast<const char*>(shared_memory);
    reduce = reinterpret_cast<float*>(shared_memory + words);
    __syncthreads();
  }

  for (; item < items; item += static_cast<int>(gridDim.x)) {
    const int tile = item / frame.splits;
    const int split = item - tile * frame.splits;
    const int last = min((split + 1) * frame.split_points, frame.num_points);
    float sum = 0.f;
#pragma unroll 2
    for (int j = split * frame.split_points + slot; j < last; j += kPointsPerPass) {
      const int next = j + kPointsPerPass;
      const float4 next_a = __ldg(points + 2 * next);
      const float4 next_b = __ldg(points + 2 * next + 1);
      sum += point_score<kShared>(planes, layout, r0, r1, r2, a, b);
      a = next_a;
      b = next_b;
    }
    sum *= layout.inv_scale;  // exact: a power of two
    const int next_item = item + static_cast<int>(gridDim.x);
    if (next_item < items) prefetch(next_item);

    // 3.20 in a fixed order: the two halves of each warp, the warps, then (several splits) the
    // splits.
    if constexpr (kTile < kWarpSize) sum += __shfl_xor_sync(0xffffffffu, sum, kTile);
    if (lane < kTile) reduce[warp * kTile + lane] = sum;
    __syncthreads();
    if (warp == 0) {
      float total = 0.f;
      for (int w = lane / kTile; w < kWarpsPerBlock; w += kWarpSize / kTile) total += reduce[w * kTile + member];
      if constexpr (kTile < kWarpSize) total += __shfl_xor_sync(0xffffffffu, total, kTile);
      const int particle = tile * kTile + member;
      if (frame.splits == 1) {
        if (lane < kTile && particle < frame.num_particles) frame.scores[particle] = total;
      } else {
        if (lane < kTile) frame.partials[split * padded_particles + particle] = total;
        __threadfence();  // each lane's split sum is visible device-wide ...
        __syncwarp();     // ... before lane 0 counts the split as done
        unsigned done = 0;
        if (lane == 0) done = atomicAdd(frame.tile_done + tile, 1u);
        done = __shfl_sync(0xffffffffu, done, 0);
        if (done == static_cast<unsigned>(frame.splits - 1)) {
          // The tile's last split: every split sum is in L2 (read past L1 with __ldcg).
          __threadfence();
          if (lane < kTile) {
            float score = 0.f;
            for (int k = 0; k < frame.splits; ++k) score += __ldcg(frame.partials + k * padded_particles + particle);
            if (particle < frame.num_particles) frame.scores[particle] = score;
          }
          if (lane == 0) frame.tile_done[tile] = 0u;  // ready for the next call
        }
      }
    }
    if (next_item < items) __syncthreads();  // reduce is read before the next item writes it
  }
}

// Splits per tile for `tiles` tiles of `points` points over `blocks` resident blocks: the least
// time for the busiest block, counted in points scored (rounds of items times points per split),
// where each round with split sums also pays their combination (a fence, a counter and a reload
// from L2 while the block waits: about as long as scoring kCombinePoints points on an H100).
// At most kMaxSplits splits, and at least kMinSplitPoints points per split.
int choose_splits(int tiles, int points, int blocks) {
  constexpr long kCombinePoints = 200;
  const int most = std::clamp(points / kMinSplitPoints, 1, kMaxSplits);
  int best_splits = 1;
  long best = std::numeric_limits<long>::max();
  for (int splits = 1; splits <= most; ++splits) {
    const long rounds = (static_cast<long>(tiles) * splits + blocks - 1) / blocks;
    const long cost = rounds * ((points + splits - 1) / splits + (splits > 1 ? kCombinePoints : 0));
    if (cost < best) {
      best = cost;
      best_splits = splits;
    }
  }
  return best_splits;
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
  return std::string(props.name) + " (sm_" + std::to_string(props.major) + std::to_string(props.minor) + ", " +
         std::to_string(props.multiProcessorCount) + " SMs)";
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

  DeviceBuffer raw_grid, planes, frame, partials, tile_done, scores;
  PinnedBuffer grid_host, frame_host, scores_host;

  std::array<int, 3> dims{0, 0, 0};
  int corners = 0;                            // 0: no valid grid on the device
  int stride_y = 0, stride_z = 0, plane = 0;  // the planes' layout (GridLayout)
  float grid_scale = 1.f;                     // GridLayout::scale of the uploaded grid
  std::array<int, 3> strides_for{0, 0, 0};    // dims whose strides are cached
  std::pair<int, int> strides{0, 0};
  int max_shared_bytes = 0;                             // dynamic shared memory a block may opt in to
  bool grid_in_shared = false;                          // the current grid's planes fit in shared memory
  int resident_blocks = 0;                              // blocks of the chosen kernel that run at once on the device
  bool counters_zero = false;                           // tile_done holds zeros (it is reset by every completed kernel)
  std::size_t staged_points = 0, staged_particles = 0;  // the frame staged by stage_frame
  bool frame_staged = false;  // stage_frame was called since the last evaluate (which rewrites the records)
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
  if (options.splits < 0 || options.splits > kMaxSplits) {
    throw std::invalid_argument("JcsdDevice: splits must be in [0, " + std::to_string(kMaxSplits) + "], got " +
                                std::to_string(options.splits));
  }
  int count = 0;
  check(cudaGetDeviceCount(&count), "cudaGetDeviceCount");
  if (options.device < 0 || options.device >= count) {
    throw std::runtime_error("CUDA device " + std::to_string(options.device) + " requested, " + std::to_string(count) +
                             " present: " + cudaGetErrorString(cudaErrorInvalidDevice));
  }
  check(cudaSetDevice(options.device), "cudaSetDevice");
  check(cudaDeviceGetAttribute(&s.sm_count, cudaDevAttrMultiProcessorCount, options.device), "cudaDeviceGetAttribute");
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
  s.grid_host.reserve(corners * kBins * sizeof(float), s.stream, "cudaHostAlloc (grid)");
  return s.grid_host.as<float>();
}

void JcsdDevice::upload_grid(const std::array<int, 3>& dims) {
  State& s = *state_;
  const std::size_t corners = static_cast<std::size_t>(dims[0]) * dims[1] * dims[2];
  if (dims[0] < 2 || dims[1] < 2 || dims[2] < 2 || corners * kBins > std::size_t{1} << 31) {
    throw std::runtime_error("JcsdDevice::upload_grid: dims must be >= 2 and the grid below 2^31 / 8 corners");
  }
  s.activate();
  s.corners = 0;  // no valid grid on the device until this upload is queued
  s.raw_grid.reserve(corners * kBins * sizeof(float), s.stream, "cudaMalloc (grid)");
  check(cudaMemcpyAsync(s.raw_grid.as<float>(), s.grid_host.as<float>(), corners * kBins * sizeof(float),
                        cudaMemcpyHostToDevice, s.stream),
        "cudaMemcpyAsync (grid)");

  if (dims != s.strides_for) {  // the search costs microseconds; models keep their size for long
    s.strides = padded_strides(dims);
    s.strides_for = dims;
  }
  const auto [stride_y, stride_z] = s.strides;
  const std::size_t plane = static_cast<std::size_t>(stride_z) * dims[2];
  if (plane * kCornerBytes >= std::size_t{1} << 31) {
    throw std::runtime_error("JcsdDevice::upload_grid: grid too large");
  }
  s.stride_y = stride_y;
  s.stride_z = stride_z;
  s.plane = static_cast<int>(plane);
  // The power of two that puts the grid's largest value in [2^(kScaleExponent - 1), 2^kScaleExponent).
  const float* values = s.grid_host.as<float>();
  const float largest = *std::max_element(values, values + corners * kBins);
  int exponent = 0;
  if (std::isfinite(largest) && largest > 0.f) std::frexp(largest, &exponent);
  s.grid_scale = std::ldexp(1.f, std::clamp(kScaleExponent - exponent, -126, 126));  // scale and 1 / scale finite
  // The planes are expanded once here, into global memory; the kernel copies them into shared
  // memory when they fit there and reads them through the read-only cache otherwise.
  const std::size_t words = static_cast<std::size_t>(plane_words(s.plane));
  s.planes.reserve(words * sizeof(float4), s.stream, "cudaMalloc (grid planes)");
  const GridLayout layout =
      make_layout(s.raw_grid.as<float4>(), nullptr, s.grid_scale, dims, stride_y, stride_z, s.plane);
  const int threads = 256;
  expand_planes_kernel<<<(s.plane + threads - 1) / threads, threads, 0, s.stream>>>(layout,
                                                                                    s.planes.as<unsigned char>());
  check(cudaGetLastError(), "expand_planes_kernel launch");
  const auto used = static_cast<std::size_t>(plane_bytes(s.plane));
  const std::size_t tail = words * sizeof(float4) - used;
  if (tail != 0) {
    check(cudaMemsetAsync(s.planes.as<unsigned char>() + used, 0, tail, s.stream), "cudaMemsetAsync (grid planes)");
  }
  const std::size_t shared_bytes = words * sizeof(float4) + kReduceBytes;
  int blocks_per_sm = 0;
  if (shared_bytes <= static_cast<std::size_t>(s.max_shared_bytes)) {
    check(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&blocks_per_sm, score_kernel<true>, kThreadsPerBlock,
                                                        shared_bytes),
          "cudaOccupancyMaxActiveBlocksPerMultiprocessor");
  }
  s.grid_in_shared = blocks_per_sm > 0;
  if (!s.grid_in_shared) {
    check(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&blocks_per_sm, score_kernel<false>, kThreadsPerBlock,
                                                        kReduceBytes),
          "cudaOccupancyMaxActiveBlocksPerMultiprocessor");
  }
  check(cudaEventRecord(s.grid_uploaded, s.stream), "cudaEventRecord");
  s.resident_blocks = std::max(1, blocks_per_sm) * s.sm_count;
  s.dims = dims;
  s.corners = static_cast<int>(corners);
}

FrameStaging JcsdDevice::stage_frame(std::size_t points, std::size_t particles) {
  State& s = *state_;
  if (points > kMaxItems) throw std::runtime_error("JcsdDevice: more than 2^24 points");
  if (particles > kMaxItems) throw std::runtime_error("JcsdDevice: more than 2^24 particles");
  s.activate();
  // One buffer, points then particles (both 16-byte records), so one copy uploads the frame.
  s.frame_host.reserve(std::max<std::size_t>(points * sizeof(PointRecord) + particles * sizeof(ParticleRecord), 1),
                       s.stream, "cudaHostAlloc (frame)");
  s.staged_points = points;
  s.staged_particles = particles;
  s.frame_staged = true;
  auto* base = s.frame_host.as<unsigned char>();
  return {reinterpret_cast<PointRecord*>(base), reinterpret_cast<ParticleRecord*>(base + points * sizeof(PointRecord))};
}

void JcsdDevice::evaluate(std::size_t points, std::size_t particles, float* scores) {
  State& s = *state_;
  if (particles == 0) return;
  if (s.corners == 0)
    throw std::runtime_error("CUDA JCSD: no grid on the device (none uploaded, or the upload failed)");
  if (!s.frame_staged || points != s.staged_points || particles != s.staged_particles) {
    throw std::runtime_error("JcsdDevice::evaluate: no frame staged with these counts (stage_frame first)");
  }
  s.frame_staged = false;
  if (points == 0) {
    std::fill(scores, scores + particles, 0.f);
    return;
  }
  s.activate();
  const int num_points = static_cast<int>(points);
  const int num_particles = static_cast<int>(particles);
  const int tiles = (num_particles + kTile - 1) / kTile;
  const int splits = std::min(
      s.options.splits > 0 ? s.options.splits : choose_splits(tiles, num_points, s.resident_blocks), num_points);
  const int split_points = (num_points + splits - 1) / splits;
  const int blocks = std::min(tiles * splits, s.resident_blocks);
  const std::size_t shared_bytes =
      s.grid_in_shared ? static_cast<std::size_t>(plane_words(s.plane)) * sizeof(float4) + kReduceBytes : kReduceBytes;

  const std::size_t frame_bytes = points * sizeof(PointRecord) + particles * sizeof(ParticleRecord);
  s.frame.reserve(frame_bytes + kFramePadBytes, s.stream, "cudaMalloc (frame)");
  s.scores.reserve(particles * sizeof(float), s.stream, "cudaMalloc (scores)");
  s.scores_host.reserve(particles * sizeof(float), s.stream, "cudaHostAlloc (scores)");
  if (splits > 1) {
    const std::size_t padded = static_cast<std::size_t>(tiles) * kTile;
    s.partials.reserve(static_cast<std::size_t>(splits) * padded * sizeof(float), s.stream, "cudaMalloc (split sums)");
    if (s.tile_done.reserve(static_cast<std::size_t>(tiles) * sizeof(unsigned), s.stream, "cudaMalloc (counters)")) {
      s.counters_zero = false;
    }
    if (!s.counters_zero) {
      check(
          cudaMemsetAsync(s.tile_done.as<unsigned>(), 0, static_cast<std::size_t>(tiles) * sizeof(unsigned), s.stream),
          "cudaMemsetAsync (counters)");
    }
  }

  // The kernel reads each point's bins as byte offsets of their planes (the hue plane of hue_bin,
  // the gray plane of gray_bin) and its weights as __half2 (w, w).
  const int hue_plane = s.plane * static_cast<int>(sizeof(HueElement));
  const int gray_plane = s.plane * static_cast<int>(sizeof(GrayElement));
  auto* records = s.frame_host.as<PointRecord>();
  for (std::size_t j = 0; j < points; ++j) {
    PointRecord& r = records[j];
    if (r.hue_bin < 0 || r.hue_bin > 5 || (r.gray_bin != 6 && r.gray_bin != 7)) {
      throw std::runtime_error("JcsdDevice::evaluate: point " + std::to_string(j) + " has a bin outside the SMR");
    }
    r.hue_bin *= hue_plane;
    r.gray_bin = kHuePlanes * hue_plane + (r.gray_bin - kHuePlanes) * gray_plane;
    for (float* w : {&r.w_lo, &r.w_hi, &r.w_gray}) {
      const unsigned bits = half2_bits(*w, *w);
      std::memcpy(w, &bits, sizeof bits);
    }
  }

  s.counters_zero = false;  // until this call's kernel has completed (it leaves them zero)
  check(cudaEventRecord(s.begin, s.stream), "cudaEventRecord");
  check(cudaMemcpyAsync(s.frame.as<void>(), s.frame_host.as<void>(), frame_bytes, cudaMemcpyHostToDevice, s.stream),
        "cudaMemcpyAsync (frame)");
  const float4* device_points = s.frame.as<float4>();
  const GridLayout layout = make_layout(s.raw_grid.as<float4>(), s.planes.as<float4>(), s.grid_scale, s.dims,
                                        s.stride_y, s.stride_z, s.plane);
  const Frame frame{device_points,
                    num_points,
                    device_points + 2 * points,
                    num_particles,
                    splits,
                    split_points,
                    s.partials.as<float>(),
                    s.tile_done.as<unsigned>(),
                    s.scores.as<float>()};
  check(cudaEventRecord(s.kernel_begin, s.stream), "cudaEventRecord");
  if (s.grid_in_shared) {
    score_kernel<true><<<blocks, kThreadsPerBlock, shared_bytes, s.stream>>>(layout, frame);
  } else {
    score_kernel<false><<<blocks, kThreadsPerBlock, shared_bytes, s.stream>>>(layout, frame);
  }
  check(cudaGetLastError(), "score_kernel launch");
  check(cudaEventRecord(s.kernel_end, s.stream), "cudaEventRecord");
  check(cudaMemcpyAsync(s.scores_host.as<void>(), s.scores.as<void>(), particles * sizeof(float),
                        cudaMemcpyDeviceToHost, s.stream),
        "cudaMemcpyAsync (scores)");
  check(cudaEventRecord(s.end, s.stream), "cudaEventRecord");
  check(cudaStreamSynchronize(s.stream), "score_kernel");
  s.counters_zero = true;
  std::memcpy(scores, s.scores_host.as<float>(), particles * sizeof(float));
  check(cudaEventElapsedTime(&s.timing.kernel_ms, s.kernel_begin, s.kernel_end), "cudaEventElapsedTime");
  check(cudaEventElapsedTime(&s.timing.transfer_ms, s.begin, s.end), "cudaEventElapsedTime");
  s.timing.splits = splits;
}

DeviceTiming JcsdDevice::last_timing() const { return state_->timing; }

const std::string& JcsdDevice::description() const { return state_->description; }

}  // namespace mfot::cuda_detail
