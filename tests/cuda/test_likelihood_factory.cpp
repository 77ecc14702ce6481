// make_likelihood and cuda_available: these run with or without a GPU.

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "mfot/cuda/likelihood_factory.hpp"
#include "mfot/jcsd_likelihood.hpp"
#include "random_scene.hpp"

namespace mfot {
namespace {

using test::random_scene;
using test::RandomScene;

std::vector<float> scores_of(Likelihood& likelihood, const RandomScene& scene) {
  likelihood.set_model(scene.model);
  std::vector<float> scores(scene.particles.size());
  likelihood.evaluate(scene.particles, scene.data, scores);
  return scores;
}

TEST(LikelihoodFactory, CpuRequestGivesTheCpuJcsd) {
  const RandomScene scene = random_scene(600, 500, 40, 0.01f, 0.1f, 1);
  LikelihoodOptions options;
  options.backend = LikelihoodBackend::kCpu;
  options.cpu_threads = 2;
  LikelihoodChoice choice = make_likelihood(options);
  ASSERT_NE(choice.likelihood, nullptr);
  EXPECT_EQ(choice.backend, "jcsd-cpu");
  EXPECT_EQ(choice.likelihood->name(), "jcsd-cpu");
  EXPECT_FALSE(choice.note.empty());
  JcsdLikelihood direct;
  EXPECT_EQ(scores_of(*choice.likelihood, scene), scores_of(direct, scene));
}

TEST(LikelihoodFactory, PointToPointRequestGivesAWorkingBaseline) {
  RandomScene scene = random_scene(800, 600, 0, 0.f, 0.f, 2);
  Pose displaced = scene.truth;
  displaced.translation.x() += 0.05f;
  scene.particles = {scene.truth, displaced};
  LikelihoodOptions options;
  options.backend = LikelihoodBackend::kPointToPoint;
  LikelihoodChoice choice = make_likelihood(options);
  EXPECT_EQ(choice.backend, "point-to-point");
  EXPECT_EQ(choice.likelihood->name(), "point-to-point");
  const std::vector<float> scores = scores_of(*choice.likelihood, scene);
  EXPECT_GT(scores[0], scores[1]);
  EXPECT_GT(scores[0], 0.f);
}

TEST(LikelihoodFactory, AutoUsesTheGpuExactlyWhenOneIsAvailable) {
  std::string why;
  const bool gpu = cuda_available(&why);
  LikelihoodChoice choice = make_likelihood({});
  ASSERT_NE(choice.likelihood, nullptr);
  if (gpu) {
    EXPECT_EQ(choice.backend, "jcsd-cuda") << choice.note;
  } else {
    EXPECT_FALSE(why.empty());
    EXPECT_EQ(choice.backend, "jcsd-cpu");
    EXPECT_NE(choice.note.find(why), std::string::npos) << choice.note;
  }
  // Whatever was chosen scores like the CPU JCSD.
  const RandomScene scene = random_scene(600, 500, 40, 0.01f, 0.1f, 3);
  JcsdLikelihood direct;
  const std::vector<float> expected = scores_of(direct, scene);
  const std::vector<float> got = scores_of(*choice.likelihood, scene);
  for (std::size_t i = 0; i < expected.size(); ++i)
    EXPECT_NEAR(got[i], expected[i], kCudaJcsdRelativeError * expected[i] + 1e-9f);
}

TEST(LikelihoodFactory, UnusableCudaRequestFailsWithTheReason) {
  LikelihoodOptions options;
  options.backend = LikelihoodBackend::kCuda;
  options.cuda_device = 4096;  // no machine has this device, with or without CUDA
  std::string message;
  try {
    make_likelihood(options);
  } catch (const std::runtime_error& error) {
    message = error.what();
  }
  ASSERT_FALSE(message.empty()) << "an explicit cuda backend that cannot start must throw";
  EXPECT_NE(message.find("'cuda' requested"), std::string::npos) << message;
  EXPECT_NE(message.find("4096"), std::string::npos) << message;
  std::string why;
  if (cuda_available(&why)) {
    EXPECT_NE(message.find("invalid device ordinal"), std::string::npos) << message;
  } else {
    EXPECT_NE(message.find(why), std::string::npos) << message;
  }
}

TEST(LikelihoodFactory, UnusableCudaUnderAutoFallsBackToTheCpuWithTheReason) {
  LikelihoodOptions options;
  options.backend = LikelihoodBackend::kAuto;
  options.cuda_device = 4096;
  LikelihoodChoice choice = make_likelihood(options);
  EXPECT_EQ(choice.backend, "jcsd-cpu");
  EXPECT_NE(choice.note.find("CUDA not used"), std::string::npos) << choice.note;
  const RandomScene scene = random_scene(300, 200, 10, 0.01f, 0.1f, 4);
  JcsdLikelihood direct;
  EXPECT_EQ(scores_of(*choice.likelihood, scene), scores_of(direct, scene));
}

TEST(LikelihoodFactory, RejectsInvalidOptions) {
  LikelihoodOptions options;
  options.cpu_threads = 0;
  EXPECT_THROW(make_likelihood(options), std::invalid_argument);
  options.cpu_threads = 257;
  EXPECT_THROW(make_likelihood(options), std::invalid_argument);
  options = {};
  options.cuda_device = -1;
  EXPECT_THROW(make_likelihood(options), std::invalid_argument);
  options = {};
  options.grid.cell_size = -0.01f;
  EXPECT_THROW(make_likelihood(options), std::invalid_argument);
  options = {};
  options.backend = static_cast<LikelihoodBackend>(42);
  EXPECT_THROW(make_likelihood(options), std::invalid_argument);
}

TEST(LikelihoodFactory, CudaAvailableExplainsAFalse) {
  std::string why;
  if (!cuda_available(&why)) {
    EXPECT_FALSE(why.empty());
  } else {
    EXPECT_TRUE(why.empty());
  }
  EXPECT_EQ(cuda_available(nullptr), cuda_available(&why));
}

}  // namespace
}  // namespace mfot
