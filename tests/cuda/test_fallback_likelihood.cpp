// FallbackLikelihood with a scripted primary: runs without a GPU.

#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "mfot/cuda/fallback_likelihood.hpp"
#include "mfot/jcsd_likelihood.hpp"
#include "random_scene.hpp"

namespace mfot {
namespace {

using test::random_scene;
using test::RandomScene;

// A primary whose set_model / evaluate fail on the calls listed, like a GPU running out of
// memory; otherwise it scores every particle with `score`.
class ScriptedPrimary final : public Likelihood {
 public:
  struct Script {
    std::vector<int> failing_set_models;  // 0-based call numbers
    std::vector<int> failing_evaluates;
    float score = 7.f;
  };
  explicit ScriptedPrimary(Script script) : script_(std::move(script)) {}
  std::string_view name() const override { return "scripted-gpu"; }
  void set_model(const ObjectModel&) override {
    if (fails(script_.failing_set_models, set_model_calls_++))
      throw std::runtime_error("CUDA cudaMalloc (grid) failed: out of memory");
  }
  void evaluate(std::span<const Pose>, const HypothesisData&, std::span<float> scores) override {
    if (fails(script_.failing_evaluates, evaluate_calls_++))
      throw std::runtime_error("CUDA score_kernel failed: unspecified launch failure");
    std::fill(scores.begin(), scores.end(), script_.score);
  }

 private:
  static bool fails(const std::vector<int>& calls, int n) {
    return std::find(calls.begin(), calls.end(), n) != calls.end();
  }
  Script script_;
  int set_model_calls_ = 0;
  int evaluate_calls_ = 0;
};

// Counts the models it receives, delegating to the CPU JCSD.
class CountingCpu final : public Likelihood {
 public:
  explicit CountingCpu(int* set_models) : set_models_(set_models) {}
  std::string_view name() const override { return "jcsd-cpu"; }
  void set_model(const ObjectModel& model) override {
    ++*set_models_;
    cpu_.set_model(model);
  }
  void evaluate(std::span<const Pose> particles, const HypothesisData& data, std::span<float> scores) override {
    cpu_.evaluate(particles, data, scores);
  }

 private:
  int* set_models_;
  JcsdLikelihood cpu_;
};

std::vector<float> cpu_scores(const RandomScene& scene) {
  JcsdLikelihood cpu;
  cpu.set_model(scene.model);
  std::vector<float> scores(scene.particles.size());
  cpu.evaluate(scene.particles, scene.data, scores);
  return scores;
}

TEST(FallbackLikelihood, ScoresAFailedFrameOnTheFallbackAndRetriesThePrimary) {
  const RandomScene scene = random_scene(600, 400, 30, 0.01f, 0.1f, 21);
  int fallback_models = 0;
  FallbackLikelihood likelihood(std::make_unique<ScriptedPrimary>(ScriptedPrimary::Script{{}, {1}, 7.f}),
                                std::make_unique<CountingCpu>(&fallback_models));
  EXPECT_EQ(likelihood.name(), "scripted-gpu");
  likelihood.set_model(scene.model);
  std::vector<float> scores(scene.particles.size());

  likelihood.evaluate(scene.particles, scene.data, scores);  // primary works
  EXPECT_EQ(scores, std::vector<float>(scores.size(), 7.f));
  EXPECT_EQ(fallback_models, 0);  // the CPU grid is only built when needed
  EXPECT_EQ(likelihood.last_error(), "");

  likelihood.evaluate(scene.particles, scene.data, scores);  // primary fails: this frame on the CPU
  EXPECT_EQ(scores, cpu_scores(scene));
  EXPECT_EQ(fallback_models, 1);
  EXPECT_EQ(likelihood.fallback_frames(), 1u);
  EXPECT_NE(likelihood.last_error().find("unspecified launch failure"), std::string::npos);

  likelihood.evaluate(scene.particles, scene.data, scores);  // primary recovered
  EXPECT_EQ(scores, std::vector<float>(scores.size(), 7.f));
  EXPECT_EQ(likelihood.fallback_frames(), 1u);
}

TEST(FallbackLikelihood, APrimaryThatLostTheModelIsOfferedItAgain) {
  const RandomScene scene = random_scene(600, 400, 30, 0.01f, 0.1f, 22);
  int fallback_models = 0;
  FallbackLikelihood likelihood(std::make_unique<ScriptedPrimary>(ScriptedPrimary::Script{{0, 1}, {}, 5.f}),
                                std::make_unique<CountingCpu>(&fallback_models));
  likelihood.set_model(scene.model);  // set_model call 0 fails
  EXPECT_NE(likelihood.last_error().find("out of memory"), std::string::npos);
  std::vector<float> scores(scene.particles.size());
  likelihood.evaluate(scene.particles, scene.data, scores);  // retry (call 1) fails: CPU
  EXPECT_EQ(scores, cpu_scores(scene));
  EXPECT_EQ(likelihood.fallback_frames(), 1u);
  likelihood.evaluate(scene.particles, scene.data, scores);  // retry (call 2) works: primary
  EXPECT_EQ(scores, std::vector<float>(scores.size(), 5.f));
  EXPECT_EQ(likelihood.fallback_frames(), 1u);
  EXPECT_EQ(fallback_models, 1);
}

TEST(FallbackLikelihood, ANewModelReachesTheFallbackBeforeItScores) {
  const RandomScene first = random_scene(600, 400, 30, 0.01f, 0.1f, 23);
  const RandomScene second = random_scene(300, 400, 30, 0.01f, 0.1f, 24, 0.2f);
  int fallback_models = 0;
  FallbackLikelihood likelihood(std::make_unique<ScriptedPrimary>(ScriptedPrimary::Script{{}, {0, 1}, 1.f}),
                                std::make_unique<CountingCpu>(&fallback_models));
  std::vector<float> scores(first.particles.size());
  likelihood.set_model(first.model);
  likelihood.evaluate(first.particles, first.data, scores);
  EXPECT_EQ(scores, cpu_scores(first));
  likelihood.set_model(second.model);
  likelihood.evaluate(second.particles, second.data, scores);
  EXPECT_EQ(scores, cpu_scores(second));
  EXPECT_EQ(fallback_models, 2);
}

TEST(FallbackLikelihood, PassesCallerErrorsThrough) {
  const RandomScene scene = random_scene(100, 50, 5, 0.01f, 0.1f, 25);
  FallbackLikelihood likelihood(std::make_unique<JcsdLikelihood>(), std::make_unique<JcsdLikelihood>());
  likelihood.set_model(scene.model);
  std::vector<float> wrong_size(scene.particles.size() + 1);
  EXPECT_THROW(likelihood.evaluate(scene.particles, scene.data, wrong_size), std::invalid_argument);
  EXPECT_EQ(likelihood.fallback_frames(), 0u);
}

TEST(FallbackLikelihood, RejectsMissingBackends) {
  EXPECT_THROW(FallbackLikelihood(nullptr, std::make_unique<JcsdLikelihood>()), std::invalid_argument);
  EXPECT_THROW(FallbackLikelihood(std::make_unique<JcsdLikelihood>(), nullptr), std::invalid_argument);
}

}  // namespace
}  // namespace mfot
