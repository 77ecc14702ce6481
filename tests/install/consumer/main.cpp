// Links the installed mfot: scores the true pose of a small coloured box against a displaced one
// with the CPU JCSD chosen through the public factory. Exit 0 only when the true pose wins.
#include <cstdio>
#include <vector>

#include "mfot/cuda/likelihood_factory.hpp"
#include "mfot/smr_feature.hpp"

int main() {
  mfot::ObjectModel model;
  for (int i = 0; i < 10; ++i) {
    for (int j = 0; j < 10; ++j) {
      const mfot::Rgb8 color{static_cast<std::uint8_t>(25 * i), static_cast<std::uint8_t>(25 * j), 90};
      model.cloud.push_back(Eigen::Vector3f(0.005f * i, 0.005f * j, 0.f), color);
    }
  }
  model.features = mfot::compute_smr(model.cloud.colors);
  mfot::HypothesisData data;
  const Eigen::Vector3f offset(0.1f, 0.f, 0.8f);
  for (std::size_t i = 0; i < model.cloud.size(); ++i) data.points.push_back(model.cloud.positions[i] + offset);
  data.features = model.features;
  data.colors = model.cloud.colors;

  mfot::LikelihoodOptions options;
  options.backend = mfot::LikelihoodBackend::kCpu;
  mfot::LikelihoodChoice choice = mfot::make_likelihood(options);
  choice.likelihood->set_model(model);
  std::vector<mfot::Pose> particles(2);
  particles[0].translation = offset;
  particles[1].translation = offset + Eigen::Vector3f(0.03f, 0.f, 0.f);
  std::vector<float> scores(2);
  choice.likelihood->evaluate(particles, data, scores);
  std::printf("%s: true pose %.4f, displaced %.4f\n", choice.backend.c_str(), scores[0], scores[1]);
  return scores[0] > scores[1] && scores[0] > 0.f ? 0 : 1;
}
