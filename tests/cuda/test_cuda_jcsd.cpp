// CUDA JCSD likelihood against the CPU JCSD (the reference). These tests need a CUDA device and
// are skipped, with the reason, when the build has no CUDA or no device is present.

#include "mfot/cuda/fallback_likelihood.hpp"
#include "mfot/cuda/likelihood_factory.hpp"
#include "mfot/jcsd_likelihood.hpp"
#include "mfot/particle_filter.hpp"
#include "random_scene.hpp"

#if MFOT_HAVE_CUDA
#include "mfot/cuda/cuda_jcsd_likelihood.hpp"
#endif

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace mfot {
namespace {

using test::random_scene;
using test::RandomScene;

class CudaJcsd : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string why;
    if (!cuda_available(&why)) GTEST_SKIP() << "CUDA JCSD not testable here: " << why;
  }
};

#if MFOT_HAVE_CUDA

std::vector<float> cpu_scores(const RandomScene& scene, const JcsdGridOptions& grid = {}) {
  JcsdLikelihood cpu(JcsdLikelihoodOptions{grid, 1});
  cpu.set_model(scene.model);
  std::vector<float> scores(scene.particles.size());
  cpu.evaluate(scene.particles, scene.data, scores);
  return scores;
}

// Scores are sums of non-negative terms: the 16-bit grid's roundings stay relative
// (kCudaJcsdRelativeError). Returns the worst relative difference.
double expect_parity(const std::vector<float>& cpu, const std::vector<float>& gpu) {
  EXPECT_EQ(cpu.size(), gpu.size());
  double worst = 0.0;
  for (std::size_t i = 0; i < std::min(cpu.size(), gpu.size()); ++i) {
    EXPECT_TRUE(std::isfinite(gpu[i])) << "particle " << i;
    EXPECT_NEAR(gpu[i], cpu[i], kCudaJcsdRelativeError * std::abs(cpu[i]) + 1e-9f) << "particle " << i;
    if (cpu[i] != 0.f) worst = std::max(worst, std::abs(static_cast<double>(gpu[i]) - cpu[i]) / std::abs(cpu[i]));
  }
  return worst;
}

// Largest difference of the particle filter's weights (3.21, the default lambda) from the two
// score vectors: what the filter would do differently.
double weight_difference(const std::vector<float>& cpu, const std::vector<float>& gpu) {
  const float lambda = ParticleFilterOptions{}.lambda;
  std::vector<float> w_cpu(cpu.size()), w_gpu(gpu.size());
  likelihood_weights(cpu, lambda, w_cpu);
  likelihood_weights(gpu, lambda, w_gpu);
  double worst = 0.0;
  for (std::size_t i = 0; i < cpu.size(); ++i)
    worst = std::max(worst, std::abs(static_cast<double>(w_gpu[i]) - w_cpu[i]));
  return worst;
}

TEST(CudaJcsdOptions, RejectsOutOfRangeValuesBeforeTouchingTheDevice) {
  CudaJcsdLikelihoodOptions options;
  for (const int splits : {-1, 65}) {
    options.point_splits = splits;
    EXPECT_THROW(CudaJcsdLikelihood{options}, std::invalid_argument) << splits;
  }
  options = {};
  options.device = -1;
  EXPECT_THROW(CudaJcsdLikelihood{options}, std::invalid_argument);
  options = {};
  options.grid.cell_size = 0.f;
  EXPECT_THROW(CudaJcsdLikelihood{options}, std::invalid_argument);
}

struct ParityCase {
  std::size_t model_points, data_points, particles;
  float sigma_t, sigma_r;
  int point_splits;      // 0: chosen per call
  float extent = 0.12f;  // model size in metres: 0.5 m puts the grid past shared memory
};

class CudaJcsdParity : public CudaJcsd, public ::testing::WithParamInterface<ParityCase> {};

TEST_P(CudaJcsdParity, MatchesCpuJcsd) {
  const ParityCase c = GetParam();
  const RandomScene scene = random_scene(c.model_points, c.data_points, c.particles, c.sigma_t, c.sigma_r,
                                         0x5eed + c.particles * 7 + c.data_points, c.extent);
  CudaJcsdLikelihoodOptions options;
  options.point_splits = c.point_splits;
  CudaJcsdLikelihood gpu(options);
  gpu.set_model(scene.model);
  std::vector<float> scores(scene.particles.size(), std::numeric_limits<float>::quiet_NaN());
  gpu.evaluate(scene.particles, scene.data, scores);
  const std::vector<float> cpu = cpu_scores(scene);
  const double worst = expect_parity(cpu, scores);
  // The filter's weights (sum 1) move by far less than any particle's share of them.
  const double weights = weight_difference(cpu, scores);
  EXPECT_LT(weights, 1e-3);
  std::printf("[ parity   ] %zu particles x %zu points: scores within %.2e relative, weights within %.2e\n",
              c.particles, c.data_points, worst, weights);
  // The scene must exercise the arithmetic: most particles see the object.
  std::size_t positive = 0;
  for (float s : cpu) positive += s > 0.f ? 1 : 0;
  EXPECT_GT(2 * positive, cpu.size());
}

INSTANTIATE_TEST_SUITE_P(
    Shapes, CudaJcsdParity,
    ::testing::Values(ParityCase{500, 1, 3, 0.002f, 0.02f, 4},              // one point (splits capped at the points)
                      ParityCase{900, 100, 31, 0.01f, 0.1f, 0},             // one full and one partial tile
                      ParityCase{900, 900, 33, 0.01f, 0.1f, 64},            // three tiles, one particle in the last
                      ParityCase{900, 900, 2000, 0.01f, 0.1f, 0},           // the Table 4.1 size
                      ParityCase{900, 900, 2000, 0.05f, 0.6f, 0},           // wide spread: many points off the grid
                      ParityCase{2000, 5000, 257, 0.005f, 0.05f, 7},        // uneven splits of many points
                      ParityCase{300, 70, 5000, 0.02f, 0.2f, 64},           // many items per block, empty splits
                      ParityCase{3000, 900, 2000, 0.02f, 0.1f, 0, 0.5f},    // grid in global memory
                      ParityCase{3000, 900, 7000, 0.02f, 0.1f, 3, 0.5f}));  // global memory, several items per block

TEST_F(CudaJcsd, MatchesTheReferencePointScores) {
  const RandomScene scene = random_scene(700, 400, 40, 0.01f, 0.1f, 11);
  CudaJcsdLikelihood gpu;
  gpu.set_model(scene.model);
  std::vector<float> scores(scene.particles.size());
  gpu.evaluate(scene.particles, scene.data, scores);
  for (std::size_t i = 0; i < scene.particles.size(); ++i) {
    const Eigen::Isometry3f to_object = scene.particles[i].isometry().inverse();
    double reference = 0.0;
    for (std::size_t j = 0; j < scene.data.points.size(); ++j) {
      reference += jcsd_point_score(gpu.grid(), to_object * scene.data.points[j], scene.data.features[j]);
    }
    EXPECT_NEAR(scores[i], reference, kCudaJcsdRelativeError * reference + 1e-9) << "particle " << i;
  }
}

TEST_F(CudaJcsd, RepeatsBitIdenticalScoresAndWritesEveryOne) {
  const RandomScene scene = random_scene(900, 900, 1000, 0.01f, 0.1f, 12);
  CudaJcsdLikelihood gpu;
  gpu.set_model(scene.model);
  std::vector<float> first(scene.particles.size(), std::numeric_limits<float>::quiet_NaN());
  std::vector<float> second(scene.particles.size(), std::numeric_limits<float>::quiet_NaN());
  gpu.evaluate(scene.particles, scene.data, first);
  gpu.evaluate(scene.particles, scene.data, second);
  for (float s : first) ASSERT_TRUE(std::isfinite(s));
  EXPECT_EQ(0, std::memcmp(first.data(), second.data(), first.size() * sizeof(float)));
  EXPECT_GT(gpu.last_timing().kernel_ms, 0.f);
  EXPECT_GE(gpu.last_timing().transfer_ms, gpu.last_timing().kernel_ms);
}

TEST_F(CudaJcsd, EverySplitCountGivesTheSameScoresAndReportsItsShape) {
  const RandomScene scene = random_scene(900, 900, 300, 0.01f, 0.1f, 19);
  const std::vector<float> cpu = cpu_scores(scene);
  for (const int splits : {0, 1, 2, 5, 16, 64}) {
    CudaJcsdLikelihoodOptions options;
    options.point_splits = splits;
    CudaJcsdLikelihood gpu(options);
    gpu.set_model(scene.model);
    std::vector<float> scores(scene.particles.size(), std::numeric_limits<float>::quiet_NaN());
    gpu.evaluate(scene.particles, scene.data, scores);
    SCOPED_TRACE(splits);
    expect_parity(cpu, scores);
    const int used = gpu.last_timing().point_splits;
    if (splits != 0) {
      EXPECT_EQ(used, splits);
    }
    EXPECT_TRUE(used >= 1 && used <= 64) << used;
  }
}

TEST_F(CudaJcsd, FollowsModelsThatGrowAndShrink) {
  CudaJcsdLikelihood gpu;
  for (const auto& [points, extent] : {std::pair{200, 0.05f}, std::pair{3000, 0.4f}, std::pair{100, 0.03f}}) {
    const RandomScene scene = random_scene(static_cast<std::size_t>(points), 600, 300, 0.005f, 0.05f,
                                           static_cast<std::uint64_t>(points), extent);
    gpu.set_model(scene.model);
    std::vector<float> scores(scene.particles.size());
    gpu.evaluate(scene.particles, scene.data, scores);
    expect_parity(cpu_scores(scene), scores);
  }
}

TEST_F(CudaJcsd, UsesTheGridCellSizeOption) {
  const RandomScene scene = random_scene(900, 900, 100, 0.01f, 0.1f, 13);
  CudaJcsdLikelihoodOptions options;
  options.grid.cell_size = 0.008f;
  options.grid.padding_cells = 2;
  CudaJcsdLikelihood gpu(options);
  gpu.set_model(scene.model);
  std::vector<float> scores(scene.particles.size());
  gpu.evaluate(scene.particles, scene.data, scores);
  expect_parity(cpu_scores(scene, options.grid), scores);
}

TEST_F(CudaJcsd, EmptyInputsGiveZeroScores) {
  const RandomScene scene = random_scene(500, 300, 50, 0.01f, 0.1f, 14);
  CudaJcsdLikelihood gpu;
  std::vector<float> scores(scene.particles.size(), 1.f);
  gpu.evaluate(scene.particles, scene.data, scores);  // no model yet
  for (float s : scores) EXPECT_EQ(s, 0.f);
  gpu.set_model(scene.model);
  std::fill(scores.begin(), scores.end(), 1.f);
  gpu.evaluate(scene.particles, HypothesisData{}, scores);
  for (float s : scores) EXPECT_EQ(s, 0.f);
  std::vector<float> none;
  EXPECT_NO_THROW(gpu.evaluate({}, scene.data, none));
  gpu.set_model(ObjectModel{});
  std::fill(scores.begin(), scores.end(), 1.f);
  gpu.evaluate(scene.particles, scene.data, scores);
  for (float s : scores) EXPECT_EQ(s, 0.f);
}

TEST_F(CudaJcsd, RejectsMalformedInputs) {
  RandomScene scene = random_scene(500, 300, 50, 0.01f, 0.1f, 15);
  CudaJcsdLikelihood gpu;
  gpu.set_model(scene.model);
  std::vector<float> short_scores(scene.particles.size() - 1);
  EXPECT_THROW(gpu.evaluate(scene.particles, scene.data, short_scores), std::invalid_argument);
  std::vector<float> scores(scene.particles.size());
  scene.data.features[3].hue_bin = 6;
  EXPECT_THROW(gpu.evaluate(scene.particles, scene.data, scores), std::invalid_argument);
  scene.data.features[3].hue_bin = 0;
  scene.data.features[4].gray_bin = 5;
  EXPECT_THROW(gpu.evaluate(scene.particles, scene.data, scores), std::invalid_argument);
}

TEST_F(CudaJcsd, ReportsABadDeviceOrdinalWithTheCudaErrorText) {
  CudaJcsdLikelihoodOptions options;
  options.device = 1000;
  try {
    CudaJcsdLikelihood gpu(options);
    FAIL() << "device 1000 accepted";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("invalid device ordinal"), std::string::npos) << error.what();
  }
}

TEST_F(CudaJcsd, InstancesOnSeparateThreadsDoNotInterfere) {
  const RandomScene a = random_scene(900, 900, 500, 0.01f, 0.1f, 16);
  const RandomScene b = random_scene(400, 1500, 700, 0.02f, 0.2f, 17, 0.2f);
  const std::vector<float> cpu_a = cpu_scores(a);
  const std::vector<float> cpu_b = cpu_scores(b);
  std::vector<float> last_a, last_b;
  std::string error_a, error_b;
  const auto run = [](const RandomScene& scene, std::vector<float>& last, std::string& error) {
    try {
      CudaJcsdLikelihood gpu;
      gpu.set_model(scene.model);
      last.assign(scene.particles.size(), 0.f);
      for (int frame = 0; frame < 20; ++frame) gpu.evaluate(scene.particles, scene.data, last);
    } catch (const std::exception& e) {
      error = e.what();
    }
  };
  std::thread ta(run, std::cref(a), std::ref(last_a), std::ref(error_a));
  std::thread tb(run, std::cref(b), std::ref(last_b), std::ref(error_b));
  ta.join();
  tb.join();
  ASSERT_EQ(error_a, "");
  ASSERT_EQ(error_b, "");
  expect_parity(cpu_a, last_a);
  expect_parity(cpu_b, last_b);
}

TEST_F(CudaJcsd, FactoryChoosesTheGpuAndMatchesTheCpu) {
  const RandomScene scene = random_scene(900, 900, 200, 0.01f, 0.1f, 18);
  LikelihoodChoice choice = make_likelihood({});
  ASSERT_EQ(choice.backend, "jcsd-cuda") << choice.note;
  EXPECT_EQ(choice.likelihood->name(), "jcsd-cuda");
  EXPECT_NE(choice.note.find("CUDA JCSD"), std::string::npos) << choice.note;
  choice.likelihood->set_model(scene.model);
  std::vector<float> scores(scene.particles.size());
  choice.likelihood->evaluate(scene.particles, scene.data, scores);
  const auto* fallback = dynamic_cast<const FallbackLikelihood*>(choice.likelihood.get());
  ASSERT_NE(fallback, nullptr);
  EXPECT_EQ(fallback->fallback_frames(), 0u) << fallback->last_error();
  expect_parity(cpu_scores(scene), scores);
}

#else

TEST_F(CudaJcsd, NeedsACudaBuild) {}  // SetUp skips: cuda_available() is false without CUDA

#endif

}  // namespace
}  // namespace mfot
