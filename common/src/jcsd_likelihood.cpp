// JCSD hypothesis evaluation on the CPU, thesis 3.3, equations 3.18 to 3.20 (see the header for
// the steps). Per particle the points are taken in batches: first mapped to their cells (with
// AVX2 + FMA, eight points at a time; the build uses -march=native), then interpolated one point
// at a time as 8-lane vectors over the colour bins. Without AVX2 a portable loop does the same
// arithmetic in the same order (the same sums, rounded without fused multiply-adds).

#include "mfot/jcsd_likelihood.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>

#if defined(__AVX2__) && defined(__FMA__)
#include <immintrin.h>
#define MFOT_JCSD_AVX2 1
#endif

namespace mfot {
namespace {

constexpr std::size_t kLanes = 8;   // points mapped at once; the point count is padded to a multiple
constexpr std::size_t kBatch = 64;  // points mapped before they are interpolated (a multiple of kLanes)
constexpr std::size_t kSums = 2;    // interleaved per-bin sums: point j goes to sum j % 2 (even, odd)
static_assert(kBatch % kLanes == 0 && kLanes % kSums == 0);

void validate(const JcsdLikelihoodOptions& options) {
  validate(options.grid);
  if (options.threads < 1 || options.threads > 256) {
    throw std::invalid_argument("JcsdLikelihoodOptions.threads must be in [1, 256], got " +
                                std::to_string(options.threads));
  }
}

}  // namespace

// Runs one evaluate call's particle blocks on threads - 1 workers plus the caller. Workers sleep
// on a condition variable between calls.
class JcsdLikelihood::WorkerPool {
 public:
  WorkerPool(const JcsdLikelihood& owner, int threads) : owner_(owner), threads_(threads) {
    workers_.reserve(static_cast<std::size_t>(threads - 1));
    for (int t = 1; t < threads; ++t) workers_.emplace_back([this, t] { work(t); });
  }
  ~WorkerPool() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    start_.notify_all();
    for (std::thread& w : workers_) w.join();
  }
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  void run(std::span<const Pose> particles, std::span<float> scores) {
    {
      std::lock_guard lock(mutex_);
      particles_ = particles;
      scores_ = scores;
      pending_ = threads_ - 1;
      ++generation_;
    }
    start_.notify_all();
    run_block(0);
    std::unique_lock lock(mutex_);
    done_.wait(lock, [this] { return pending_ == 0; });
  }

 private:
  void run_block(int t) {
    const std::size_t n = particles_.size();
    const std::size_t begin = n * static_cast<std::size_t>(t) / static_cast<std::size_t>(threads_);
    const std::size_t end = n * static_cast<std::size_t>(t + 1) / static_cast<std::size_t>(threads_);
    owner_.score_block(particles_.subspan(begin, end - begin), scores_.subspan(begin, end - begin));
  }

  void work(int t) {
    std::uint64_t seen = 0;
    for (;;) {
      {
        std::unique_lock lock(mutex_);
        start_.wait(lock, [&] { return stop_ || generation_ != seen; });
        if (stop_) return;
        seen = generation_;
      }
      run_block(t);
      {
        std::lock_guard lock(mutex_);
        --pending_;
      }
      done_.notify_one();
    }
  }

  const JcsdLikelihood& owner_;
  const int threads_;
  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable start_;
  std::condition_variable done_;
  bool stop_ = false;
  std::uint64_t generation_ = 0;
  int pending_ = 0;
  std::span<const Pose> particles_;
  std::span<float> scores_;
};

JcsdLikelihood::JcsdLikelihood(const JcsdLikelihoodOptions& options) : options_(options) {
  validate(options_);
  if (options_.threads > 1) pool_ = std::make_unique<WorkerPool>(*this, options_.threads);
}

JcsdLikelihood::~JcsdLikelihood() = default;

void JcsdLikelihood::set_model(const ObjectModel& model) {
  grid_ = build_jcsd_grid(model, options_.grid);
  copy_corners();
}

void JcsdLikelihood::set_grid(JcsdGrid grid) {
  if (grid.values.size() != grid.num_corners() * kSmrBins) {
    throw std::invalid_argument("JcsdLikelihood::set_grid: values.size() != dims product * 8");
  }
  if (!grid.empty() && (grid.dims[0] < 2 || grid.dims[1] < 2 || grid.dims[2] < 2)) {
    throw std::invalid_argument("JcsdLikelihood::set_grid: every dimension needs >= 2 corners");
  }
  grid_ = std::move(grid);
  copy_corners();
}

void JcsdLikelihood::copy_corners() {
  const std::size_t corners = grid_.num_corners();
  if (grid_.empty()) {
    std::vector<Bins>().swap(corners_);  // no grid: nothing held
    return;
  }
  // A point outside the grid reads corners outside_corner_ + {0, 1} + {0, dims[0]} + {0, dims[0] * dims[1]}.
  const std::size_t tail = static_cast<std::size_t>(grid_.dims[0]) * (grid_.dims[1] + 1) + 2;
  corners_.assign(corners + tail, Bins{});
  for (std::size_t s = 0; s < corners; ++s)
    std::copy_n(grid_.values.data() + s * kSmrBins, kSmrBins, corners_[s].values);
  outside_corner_ = static_cast<std::int32_t>(corners);
}

void JcsdLikelihood::evaluate(std::span<const Pose> particles, const HypothesisData& data, std::span<float> scores) {
  if (scores.size() != particles.size()) {
    throw std::invalid_argument("JcsdLikelihood::evaluate: scores.size() != particles.size()");
  }
  if (data.features.size() != data.points.size()) {
    throw std::invalid_argument("JcsdLikelihood::evaluate: data.features.size() != data.points.size()");
  }
  const std::size_t n = data.points.size();
  if (grid_.empty() || n == 0) {
    std::fill(scores.begin(), scores.end(), 0.f);
    return;
  }

  padded_points_ = (n + kLanes - 1) / kLanes * kLanes;
  for (auto* v : {&x_, &y_, &z_}) v->resize(padded_points_);
  smr_.resize(padded_points_);
  for (std::size_t j = 0; j < padded_points_; ++j) {
    if (j < n) {
      const Eigen::Vector3f& p = data.points[j];
      x_[j] = p.x();
      y_[j] = p.y();
      z_[j] = p.z();
      const std::array<float, kSmrBins> h = data.features[j].dense();
      std::copy(h.begin(), h.end(), smr_[j].values);
    } else {
      x_[j] = y_[j] = z_[j] = 0.f;
      smr_[j] = Bins{};
    }
  }
  if (pool_ && particles.size() > 1) {
    pool_->run(particles, scores);
  } else {
    score_block(particles, scores);
  }
}

void JcsdLikelihood::score_block(std::span<const Pose> particles, std::span<float> scores) const {
  for (std::size_t i = 0; i < particles.size(); ++i) scores[i] = score_particle(particles[i]);
}

float JcsdLikelihood::score_particle(const Pose& particle) const {
  // u = (R^T (p - t) - origin) / l: camera point -> object frame -> grid units, as A p + c.
  const float inv_cell = 1.f / grid_.cell_size;
  const Eigen::Matrix3f a = particle.rotation.toRotationMatrix().transpose() * inv_cell;
  const Eigen::Vector3f c = -(a * particle.translation) - grid_.origin * inv_cell;
  const float max_x = static_cast<float>(grid_.dims[0] - 2);
  const float max_y = static_cast<float>(grid_.dims[1] - 2);
  const float max_z = static_cast<float>(grid_.dims[2] - 2);
  const std::int32_t sy = grid_.dims[0];  // corner strides
  const std::int32_t sz = sy * grid_.dims[1];

  const Bins* J = corners_.data();
  const float* px = x_.data();
  const float* py = y_.data();
  const float* pz = z_.data();
  const std::size_t n = padded_points_;
  // One batch: each point's cell (its corner of lowest x, y, z; outside_corner_ for points outside
  // the grid) and its position inside the cell (0 outside the grid).
  alignas(32) std::array<std::int32_t, kBatch> cell;
  alignas(32) std::array<float, kBatch> tx, ty, tz;
  std::array<float, kSmrBins> bins{};

#if defined(MFOT_JCSD_AVX2)
  const __m256 a00 = _mm256_set1_ps(a(0, 0)), a01 = _mm256_set1_ps(a(0, 1)), a02 = _mm256_set1_ps(a(0, 2));
  const __m256 a10 = _mm256_set1_ps(a(1, 0)), a11 = _mm256_set1_ps(a(1, 1)), a12 = _mm256_set1_ps(a(1, 2));
  const __m256 a20 = _mm256_set1_ps(a(2, 0)), a21 = _mm256_set1_ps(a(2, 1)), a22 = _mm256_set1_ps(a(2, 2));
  const __m256 c0 = _mm256_set1_ps(c.x()), c1 = _mm256_set1_ps(c.y()), c2 = _mm256_set1_ps(c.z());
  const __m256 zero = _mm256_setzero_ps();
  const __m256 vmax_x = _mm256_set1_ps(max_x), vmax_y = _mm256_set1_ps(max_y), vmax_z = _mm256_set1_ps(max_z);
  const __m256i vsy = _mm256_set1_epi32(sy), vsz = _mm256_set1_epi32(sz);
  const __m256i voutside = _mm256_set1_epi32(outside_corner_);
  const auto lerp = [](__m256 from, __m256 to, __m256 t) { return _mm256_fmadd_ps(t, _mm256_sub_ps(to, from), from); };
  __m256 sum_even = zero, sum_odd = zero;
  for (std::size_t begin = 0; begin < n; begin += kBatch) {
    const std::size_t count = std::min(kBatch, n - begin);
    for (std::size_t k = 0; k < count; k += kLanes) {
      const std::size_t j = begin + k;
      const __m256 x = _mm256_loadu_ps(px + j);
      const __m256 y = _mm256_loadu_ps(py + j);
      const __m256 z = _mm256_loadu_ps(pz + j);
      const __m256 ux = _mm256_fmadd_ps(a00, x, _mm256_fmadd_ps(a01, y, _mm256_fmadd_ps(a02, z, c0)));
      const __m256 uy = _mm256_fmadd_ps(a10, x, _mm256_fmadd_ps(a11, y, _mm256_fmadd_ps(a12, z, c1)));
      const __m256 uz = _mm256_fmadd_ps(a20, x, _mm256_fmadd_ps(a21, y, _mm256_fmadd_ps(a22, z, c2)));
      const __m256 fx = _mm256_floor_ps(ux);
      const __m256 fy = _mm256_floor_ps(uy);
      const __m256 fz = _mm256_floor_ps(uz);
      // False for NaN too.
      __m256 inside = _mm256_and_ps(_mm256_cmp_ps(fx, zero, _CMP_GE_OQ), _mm256_cmp_ps(fx, vmax_x, _CMP_LE_OQ));
      inside = _mm256_and_ps(inside,
                             _mm256_and_ps(_mm256_cmp_ps(fy, zero, _CMP_GE_OQ), _mm256_cmp_ps(fy, vmax_y, _CMP_LE_OQ)));
      inside = _mm256_and_ps(inside,
                             _mm256_and_ps(_mm256_cmp_ps(fz, zero, _CMP_GE_OQ), _mm256_cmp_ps(fz, vmax_z, _CMP_LE_OQ)));
      const __m256i base =
          _mm256_add_epi32(_mm256_cvttps_epi32(fx), _mm256_add_epi32(_mm256_mullo_epi32(_mm256_cvttps_epi32(fy), vsy),
                                                                     _mm256_mullo_epi32(_mm256_cvttps_epi32(fz), vsz)));
      _mm256_store_si256(
          reinterpret_cast<__m256i*>(cell.data() + k),
          _mm256_castps_si256(_mm256_blendv_ps(_mm256_castsi256_ps(voutside), _mm256_castsi256_ps(base), inside)));
      _mm256_store_ps(tx.data() + k, _mm256_and_ps(_mm256_sub_ps(ux, fx), inside));
      _mm256_store_ps(ty.data() + k, _mm256_and_ps(_mm256_sub_ps(uy, fy), inside));
      _mm256_store_ps(tz.data() + k, _mm256_and_ps(_mm256_sub_ps(uz, fz), inside));
    }
    // 3.18 for all 8 bins of point k as nested linear interpolation along x, then y, then z.
    const auto density = [&](std::size_t k) {
      const Bins* s = J + cell[k];
      const auto corner = [&](std::int32_t offset) { return _mm256_load_ps(s[offset].values); };
      const __m256 wx = _mm256_broadcast_ss(&tx[k]);
      const __m256 wy = _mm256_broadcast_ss(&ty[k]);
      const __m256 wz = _mm256_broadcast_ss(&tz[k]);
      const __m256 e00 = lerp(corner(0), corner(1), wx);
      const __m256 e10 = lerp(corner(sy), corner(sy + 1), wx);
      const __m256 e01 = lerp(corner(sz), corner(sz + 1), wx);
      const __m256 e11 = lerp(corner(sy + sz), corner(sy + sz + 1), wx);
      return lerp(lerp(e00, e10, wy), lerp(e01, e11, wy), wz);
    };
    for (std::size_t k = 0; k < count; k += kSums) {  // 3.19, h times the densities
      sum_even = _mm256_fmadd_ps(_mm256_load_ps(smr_[begin + k].values), density(k), sum_even);
      sum_odd = _mm256_fmadd_ps(_mm256_load_ps(smr_[begin + k + 1].values), density(k + 1), sum_odd);
    }
  }
  _mm256_storeu_ps(bins.data(), _mm256_add_ps(sum_even, sum_odd));
#else
  const auto lerp = [](float from, float to, float t) { return from + t * (to - from); };
  std::array<std::array<float, kSmrBins>, kSums> sums{};
  for (std::size_t begin = 0; begin < n; begin += kBatch) {
    const std::size_t count = std::min(kBatch, n - begin);
    for (std::size_t k = 0; k < count; ++k) {
      const std::size_t j = begin + k;
      const float ux = a(0, 0) * px[j] + (a(0, 1) * py[j] + (a(0, 2) * pz[j] + c.x()));
      const float uy = a(1, 0) * px[j] + (a(1, 1) * py[j] + (a(1, 2) * pz[j] + c.y()));
      const float uz = a(2, 0) * px[j] + (a(2, 1) * py[j] + (a(2, 2) * pz[j] + c.z()));
      const float fx = std::floor(ux);
      const float fy = std::floor(uy);
      const float fz = std::floor(uz);
      if (fx >= 0.f && fx <= max_x && fy >= 0.f && fy <= max_y && fz >= 0.f && fz <= max_z) {
        cell[k] =
            static_cast<std::int32_t>(fx) + static_cast<std::int32_t>(fy) * sy + static_cast<std::int32_t>(fz) * sz;
        tx[k] = ux - fx;
        ty[k] = uy - fy;
        tz[k] = uz - fz;
      } else {
        cell[k] = outside_corner_;
        tx[k] = ty[k] = tz[k] = 0.f;
      }
    }
    for (std::size_t k = 0; k < count; ++k) {
      const Bins* s = J + cell[k];
      const float* h = smr_[begin + k].values;
      std::array<float, kSmrBins>& sum = sums[k % kSums];
      for (int b = 0; b < kSmrBins; ++b) {
        const auto corner = [&](std::int32_t offset) { return s[offset].values[b]; };
        const float e00 = lerp(corner(0), corner(1), tx[k]);
        const float e10 = lerp(corner(sy), corner(sy + 1), tx[k]);
        const float e01 = lerp(corner(sz), corner(sz + 1), tx[k]);
        const float e11 = lerp(corner(sy + sz), corner(sy + sz + 1), tx[k]);
        const float density = lerp(lerp(e00, e10, ty[k]), lerp(e01, e11, ty[k]), tz[k]);
        sum[b] += h[b] * density;
      }
    }
  }
  for (int b = 0; b < kSmrBins; ++b) bins[b] = sums[0][b] + sums[1][b];
#endif
  // 3.20 with a fixed summation order, independent of the thread count.
  return ((bins[0] + bins[1]) + (bins[2] + bins[3])) + ((bins[4] + bins[5]) + (bins[6] + bins[7]));
}

}  // namespace mfot
