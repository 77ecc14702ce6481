// JCSD hypothesis evaluation on the CPU, thesis 3.3, equations 3.18 to 3.20 (see the header for
// the steps). The per-point loop runs over structure-of-arrays buffers, eight points at a time:
// with AVX2 + FMA (the build uses -march=native) as explicit gathers, otherwise as a portable
// scalar loop with the same summation order (lane j % 8, then a fixed pairwise sum).

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

constexpr std::size_t kLanes = 8;  // padding and summation width of the per-point loop

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
}

void JcsdLikelihood::set_grid(JcsdGrid grid) {
  if (grid.values.size() != grid.num_corners() * kSmrBins) {
    throw std::invalid_argument("JcsdLikelihood::set_grid: values.size() != dims product * 8");
  }
  if (!grid.empty() && (grid.dims[0] < 2 || grid.dims[1] < 2 || grid.dims[2] < 2)) {
    throw std::invalid_argument("JcsdLikelihood::set_grid: every dimension needs >= 2 corners");
  }
  grid_ = std::move(grid);
}

void JcsdLikelihood::evaluate(std::span<const Pose> particles, const HypothesisData& data,
                              std::span<float> scores) {
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
  for (auto* v : {&x_, &y_, &z_, &weight_lo_, &weight_hi_, &weight_gray_}) v->resize(padded_points_);
  for (auto* v : {&offset_lo_, &offset_hi_, &offset_gray_}) v->resize(padded_points_);
  for (std::size_t j = 0; j < padded_points_; ++j) {
    if (j < n) {
      const Eigen::Vector3f& p = data.points[j];
      const SmrFeature& h = data.features[j];
      x_[j] = p.x();
      y_[j] = p.y();
      z_[j] = p.z();
      offset_lo_[j] = h.hue_bin;
      offset_hi_[j] = (h.hue_bin + 1) % 6;
      offset_gray_[j] = h.gray_bin;
      weight_lo_[j] = h.hue_weight_lo;
      weight_hi_[j] = h.hue_weight_hi;
      weight_gray_[j] = h.gray_weight;
    } else {
      x_[j] = y_[j] = z_[j] = 0.f;
      offset_lo_[j] = offset_hi_[j] = offset_gray_[j] = 0;
      weight_lo_[j] = weight_hi_[j] = weight_gray_[j] = 0.f;
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
  const std::int32_t sx = static_cast<std::int32_t>(kSmrBins);
  const std::int32_t sy = sx * grid_.dims[0];
  const std::int32_t sz = sy * grid_.dims[1];

  const float* J = grid_.values.data();
  const float* px = x_.data();
  const float* py = y_.data();
  const float* pz = z_.data();
  const std::int32_t* ol = offset_lo_.data();
  const std::int32_t* oh = offset_hi_.data();
  const std::int32_t* og = offset_gray_.data();
  const float* wl = weight_lo_.data();
  const float* wh = weight_hi_.data();
  const float* wg = weight_gray_.data();
  const std::size_t n = padded_points_;
  std::array<float, kLanes> lanes{};

#if defined(MFOT_JCSD_AVX2)
  const __m256 a00 = _mm256_set1_ps(a(0, 0)), a01 = _mm256_set1_ps(a(0, 1)), a02 = _mm256_set1_ps(a(0, 2));
  const __m256 a10 = _mm256_set1_ps(a(1, 0)), a11 = _mm256_set1_ps(a(1, 1)), a12 = _mm256_set1_ps(a(1, 2));
  const __m256 a20 = _mm256_set1_ps(a(2, 0)), a21 = _mm256_set1_ps(a(2, 1)), a22 = _mm256_set1_ps(a(2, 2));
  const __m256 c0 = _mm256_set1_ps(c.x()), c1 = _mm256_set1_ps(c.y()), c2 = _mm256_set1_ps(c.z());
  const __m256 zero = _mm256_setzero_ps();
  const __m256 vmax_x = _mm256_set1_ps(max_x), vmax_y = _mm256_set1_ps(max_y), vmax_z = _mm256_set1_ps(max_z);
  const __m256i vsy = _mm256_set1_epi32(sy), vsz = _mm256_set1_epi32(sz);
  __m256 acc = zero;
  for (std::size_t j = 0; j < n; j += kLanes) {
    const __m256 x = _mm256_loadu_ps(px + j);
    const __m256 y = _mm256_loadu_ps(py + j);
    const __m256 z = _mm256_loadu_ps(pz + j);
    const __m256 ux = _mm256_fmadd_ps(a00, x, _mm256_fmadd_ps(a01, y, _mm256_fmadd_ps(a02, z, c0)));
    const __m256 uy = _mm256_fmadd_ps(a10, x, _mm256_fmadd_ps(a11, y, _mm256_fmadd_ps(a12, z, c1)));
    const __m256 uz = _mm256_fmadd_ps(a20, x, _mm256_fmadd_ps(a21, y, _mm256_fmadd_ps(a22, z, c2)));
    const __m256 fx = _mm256_floor_ps(ux);
    const __m256 fy = _mm256_floor_ps(uy);
    const __m256 fz = _mm256_floor_ps(uz);
    __m256 inside = _mm256_and_ps(_mm256_cmp_ps(fx, zero, _CMP_GE_OQ), _mm256_cmp_ps(fx, vmax_x, _CMP_LE_OQ));
    inside = _mm256_and_ps(inside, _mm256_and_ps(_mm256_cmp_ps(fy, zero, _CMP_GE_OQ), _mm256_cmp_ps(fy, vmax_y, _CMP_LE_OQ)));
    inside = _mm256_and_ps(inside, _mm256_and_ps(_mm256_cmp_ps(fz, zero, _CMP_GE_OQ), _mm256_cmp_ps(fz, vmax_z, _CMP_LE_OQ)));
    // Clamped so every gather stays inside the grid (max_ps returns 0 for NaN); outside points
    // are masked to 0 below.
    const __m256i ix = _mm256_cvttps_epi32(_mm256_min_ps(_mm256_max_ps(fx, zero), vmax_x));
    const __m256i iy = _mm256_cvttps_epi32(_mm256_min_ps(_mm256_max_ps(fy, zero), vmax_y));
    const __m256i iz = _mm256_cvttps_epi32(_mm256_min_ps(_mm256_max_ps(fz, zero), vmax_z));
    const __m256i base = _mm256_add_epi32(
        _mm256_slli_epi32(ix, 3), _mm256_add_epi32(_mm256_mullo_epi32(iy, vsy), _mm256_mullo_epi32(iz, vsz)));
    const __m256i lo = _mm256_add_epi32(base, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(ol + j)));
    const __m256i hi = _mm256_add_epi32(base, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(oh + j)));
    const __m256i gr = _mm256_add_epi32(base, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(og + j)));
    const __m256 w0 = _mm256_loadu_ps(wl + j);
    const __m256 w1 = _mm256_loadu_ps(wh + j);
    const __m256 w2 = _mm256_loadu_ps(wg + j);
    // 3.19 at one corner: h . J(:, corner), using only the three non-zero bins of h.
    const auto corner = [&](std::int32_t offset) {
      const __m256i o = _mm256_set1_epi32(offset);
      __m256 v = _mm256_mul_ps(w0, _mm256_i32gather_ps(J, _mm256_add_epi32(lo, o), 4));
      v = _mm256_fmadd_ps(w1, _mm256_i32gather_ps(J, _mm256_add_epi32(hi, o), 4), v);
      return _mm256_fmadd_ps(w2, _mm256_i32gather_ps(J, _mm256_add_epi32(gr, o), 4), v);
    };
    const __m256 tx = _mm256_sub_ps(ux, fx);
    const __m256 ty = _mm256_sub_ps(uy, fy);
    const __m256 tz = _mm256_sub_ps(uz, fz);
    const auto lerp = [](__m256 from, __m256 to, __m256 t) {
      return _mm256_fmadd_ps(t, _mm256_sub_ps(to, from), from);
    };
    // 3.18 as nested linear interpolation along x, then y, then z.
    const __m256 e00 = lerp(corner(0), corner(sx), tx);
    const __m256 e10 = lerp(corner(sy), corner(sx + sy), tx);
    const __m256 e01 = lerp(corner(sz), corner(sx + sz), tx);
    const __m256 e11 = lerp(corner(sy + sz), corner(sx + sy + sz), tx);
    const __m256 score = lerp(lerp(e00, e10, ty), lerp(e01, e11, ty), tz);
    acc = _mm256_add_ps(acc, _mm256_and_ps(score, inside));
  }
  _mm256_storeu_ps(lanes.data(), acc);
#else
  for (std::size_t j = 0; j < n; ++j) {
    const float ux = a(0, 0) * px[j] + a(0, 1) * py[j] + a(0, 2) * pz[j] + c.x();
    const float uy = a(1, 0) * px[j] + a(1, 1) * py[j] + a(1, 2) * pz[j] + c.y();
    const float uz = a(2, 0) * px[j] + a(2, 1) * py[j] + a(2, 2) * pz[j] + c.z();
    const float fx = std::floor(ux);
    const float fy = std::floor(uy);
    const float fz = std::floor(uz);
    if (!(fx >= 0.f && fx <= max_x && fy >= 0.f && fy <= max_y && fz >= 0.f && fz <= max_z)) continue;
    const std::int32_t base = static_cast<std::int32_t>(fx) * sx + static_cast<std::int32_t>(fy) * sy +
                              static_cast<std::int32_t>(fz) * sz;
    const std::int32_t lo = base + ol[j];
    const std::int32_t hi = base + oh[j];
    const std::int32_t gr = base + og[j];
    const auto corner = [&](std::int32_t offset) {
      return wl[j] * J[lo + offset] + wh[j] * J[hi + offset] + wg[j] * J[gr + offset];
    };
    const auto lerp = [](float from, float to, float t) { return from + t * (to - from); };
    const float tx = ux - fx;
    const float ty = uy - fy;
    const float tz = uz - fz;
    const float e00 = lerp(corner(0), corner(sx), tx);
    const float e10 = lerp(corner(sy), corner(sx + sy), tx);
    const float e01 = lerp(corner(sz), corner(sx + sz), tx);
    const float e11 = lerp(corner(sy + sz), corner(sx + sy + sz), tx);
    lanes[j % kLanes] += lerp(lerp(e00, e10, ty), lerp(e01, e11, ty), tz);
  }
#endif
  // 3.20 with a fixed summation order, independent of the thread count.
  return ((lanes[0] + lanes[1]) + (lanes[2] + lanes[3])) + ((lanes[4] + lanes[5]) + (lanes[6] + lanes[7]));
}

}  // namespace mfot
