// CPU JCSD hypothesis evaluation speed (thesis 3.3, equations 3.18-3.20): time per particle and
// per point for 10 to 5000 particles on 900 hypothesis points, single thread and with a thread
// pool, plus the point-to-point baseline ([CC13], 2.18-2.21) for comparison. Target: at most
// 10 us per particle of 900 points on one core (thesis: 290 us; point-to-point 900 us).
//
// Usage: mfot_bench_jcsd_cpu [threads=hardware concurrency]

#include "mfot/jcsd_likelihood.hpp"
#include "mfot/point_to_point_likelihood.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <thread>
#include <vector>

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

// Seconds per evaluate call: best of several timed batches, each at least 50 ms.
double seconds_per_call(mfot::Likelihood& likelihood, const std::vector<mfot::Pose>& particles,
                        const mfot::HypothesisData& data, std::vector<float>& scores) {
  likelihood.evaluate(particles, data, scores);  // warm-up
  double best = 1e30;
  for (int batch = 0; batch < 5; ++batch) {
    int calls = 0;
    const auto start = Clock::now();
    double elapsed = 0.0;
    do {
      likelihood.evaluate(particles, data, scores);
      ++calls;
      elapsed = std::chrono::duration<double>(Clock::now() - start).count();
    } while (elapsed < 0.05);
    best = std::min(best, elapsed / calls);
  }
  return best;
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

  std::printf("JCSD CPU evaluation, %zu hypothesis points, model %zu points, grid %dx%dx%d\n", kPoints,
              model.cloud.size(), single.grid().dims[0], single.grid().dims[1], single.grid().dims[2]);
  std::printf("%9s | %12s %12s %10s | %12s %12s | %12s\n", "particles", "1 thr ms", "us/particle", "ns/point",
              "pool ms", "us/particle", "p2p us/part");
  std::normal_distribution<float> noise(0.f, 1.f);
  for (const std::size_t n : {10u, 100u, 200u, 500u, 1000u, 2000u, 5000u}) {
    std::vector<mfot::Pose> particles(n);
    for (mfot::Pose& p : particles) {
      p.translation = truth.translation + 0.01f * Eigen::Vector3f(noise(rng), noise(rng), noise(rng));
      const Eigen::Vector3f axis(noise(rng), noise(rng), noise(rng));
      p.rotation = (Eigen::Quaternionf(Eigen::AngleAxisf(0.1f * noise(rng), axis.normalized())) * truth.rotation).normalized();
    }
    std::vector<float> scores(n);
    const double t1 = seconds_per_call(single, particles, data, scores);
    const double tp = seconds_per_call(pooled, particles, data, scores);
    std::printf("%9zu | %12.3f %12.2f %10.2f | %12.3f %12.2f |", n, t1 * 1e3, t1 * 1e6 / n,
                t1 * 1e9 / (static_cast<double>(n) * kPoints), tp * 1e3, tp * 1e6 / n);
    if (n <= 500) {
      const double tb = seconds_per_call(p2p, particles, data, scores);
      std::printf(" %12.2f\n", tb * 1e6 / n);
    } else {
      std::printf(" %12s\n", "-");
    }
  }
  std::printf("pool: %d threads\n", threads);
  return 0;
}
