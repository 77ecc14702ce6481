// CPU JCSD hypothesis evaluation speed (thesis 3.3, equations 3.18-3.20): time per particle and
// per point for 10 to 5000 particles on 900 hypothesis points, single thread and with a thread
// pool (min and median over repeated batches), plus the point-to-point baseline ([CC13],
// 2.18-2.21) for comparison. Target: at most 10 us per particle of 900 points on one core
// (thesis: 290 us; point-to-point 900 us).
//
// Usage: mfot_bench_jcsd_cpu [threads=hardware concurrency]

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <thread>
#include <vector>

#include "mfot/jcsd_likelihood.hpp"
#include "mfot/point_to_point_likelihood.hpp"

namespace {

using Clock = std::chrono::steady_clock;
constexpr std::size_t kPoints = 900;

// Random points on the surface of a 10 x 15 x 8 cm box with a colour per face.
mfot::ColoredCloud make_box(std::size_t n, std::mt19937_64& rng) {
  const Eigen::Vector3f half(0.05f, 0.075f, 0.04f);
  const mfot::Rgb8 colours[6] = {{255, 0, 0}, {0, 255, 255}, {255, 255, 0}, {0, 0, 255}, {0, 255, 0}, {255, 0, 255}};
  std::uniform_real_distribution<float> unit(-1.f, 1.f);
  std::uniform_int_distribution<int> face_pick(0, 5);
  mfot::ColoredCloud cloud;
  for (std::size_t k = 0; k < n; ++k) {
    const int face = face_pick(rng);
    Eigen::Vector3f p(unit(rng), unit(rng), unit(rng));
    p[face / 2] = face % 2 == 0 ? -1.f : 1.f;
    cloud.push_back(p.cwiseProduct(half), colours[face]);
  }
  return cloud;
}

struct Timing {
  double min = 0.0;     // seconds per evaluate call, fastest batch
  double median = 0.0;  // seconds per evaluate call, median batch
};

// Seconds per evaluate call over kBatches timed batches, each at least 20 ms (min and median: the
// min is the figure with the least interference from other processes, the median shows the spread).
constexpr int kBatches = 9;
Timing seconds_per_call(mfot::Likelihood& likelihood, const std::vector<mfot::Pose>& particles,
                        const mfot::HypothesisData& data, std::vector<float>& scores) {
  likelihood.evaluate(particles, data, scores);  // warm-up
  std::vector<double> batches;
  for (int batch = 0; batch < kBatches; ++batch) {
    int calls = 0;
    const auto start = Clock::now();
    double elapsed = 0.0;
    do {
      likelihood.evaluate(particles, data, scores);
      ++calls;
      elapsed = std::chrono::duration<double>(Clock::now() - start).count();
    } while (elapsed < 0.02);
    batches.push_back(elapsed / calls);
  }
  std::sort(batches.begin(), batches.end());
  return {batches.front(), batches[batches.size() / 2]};
}

}  // namespace

int main(int argc, char** argv) {
  const unsigned hardware = std::max(1u, std::thread::hardware_concurrency());
  const int threads = argc > 1 ? std::max(1, std::atoi(argv[1])) : static_cast<int>(hardware);

  std::mt19937_64 rng(42);
  mfot::ObjectModel model;
  model.cloud = make_box(1500, rng);
  model.features = mfot::compute_smr(model.cloud.colors);

  mfot::Pose truth;
  truth.translation = Eigen::Vector3f(0.05f, -0.02f, 0.9f);
  truth.rotation = Eigen::Quaternionf(Eigen::AngleAxisf(0.6f, Eigen::Vector3f(1.f, 1.f, 0.f).normalized()));
  const mfot::ColoredCloud observed = make_box(kPoints, rng);
  mfot::HypothesisData data;
  for (std::size_t k = 0; k < observed.size(); ++k) data.points.push_back(truth.isometry() * observed.positions[k]);
  data.colors = observed.colors;
  data.features = mfot::compute_smr(data.colors);

  mfot::JcsdLikelihood single(mfot::JcsdLikelihoodOptions{{}, 1});
  mfot::JcsdLikelihood pooled(mfot::JcsdLikelihoodOptions{{}, threads});
  mfot::PointToPointLikelihood p2p;
  single.set_model(model);
  pooled.set_model(model);
  p2p.set_model(model);

#if defined(__AVX2__) && defined(__FMA__)
  const char* path = "AVX2+FMA";
#else
  const char* path = "portable (no AVX2+FMA)";
#endif
  std::printf("JCSD CPU evaluation (%s), %zu hypothesis points, model %zu points, grid %dx%dx%d\n", path, kPoints,
              model.cloud.size(), single.grid().dims[0], single.grid().dims[1], single.grid().dims[2]);
  std::printf("us per particle (min and median over %d batches of >= 20 ms); ns per point from the min\n", kBatches);
  std::printf("%9s | %-24s | %-15s | %s\n", "", "one thread", "pool", "point-to-point");
  std::printf("%9s | %7s %7s %8s | %7s %7s | %7s\n", "particles", "min", "median", "ns/point", "min", "median", "min");
  std::normal_distribution<float> noise(0.f, 1.f);
  for (const std::size_t n : {10u, 100u, 200u, 500u, 1000u, 2000u, 5000u}) {
    std::vector<mfot::Pose> particles(n);
    for (mfot::Pose& p : particles) {
      p.translation = truth.translation + 0.01f * Eigen::Vector3f(noise(rng), noise(rng), noise(rng));
      const Eigen::Vector3f axis(noise(rng), noise(rng), noise(rng));
      p.rotation =
          (Eigen::Quaternionf(Eigen::AngleAxisf(0.1f * noise(rng), axis.normalized())) * truth.rotation).normalized();
    }
    std::vector<float> scores(n);
    const double per_particle = 1e6 / static_cast<double>(n);
    const Timing t1 = seconds_per_call(single, particles, data, scores);
    const Timing tp = seconds_per_call(pooled, particles, data, scores);
    std::printf("%9zu | %7.2f %7.2f %8.2f | %7.2f %7.2f |", n, t1.min * per_particle, t1.median * per_particle,
                t1.min * per_particle * 1e3 / kPoints, tp.min * per_particle, tp.median * per_particle);
    if (n <= 500) {
      const Timing tb = seconds_per_call(p2p, particles, data, scores);
      std::printf(" %7.2f\n", tb.min * per_particle);
    } else {
      std::printf(" %7s\n", "-");
    }
  }
  std::printf("pool: %d threads\n", threads);
  return 0;
}
