#pragma once
// Random but reproducible likelihood inputs for the backend tests: a coloured model, hypothesis
// data seen from a true pose (with noise and outliers) and particles scattered around it.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "mfot/likelihood.hpp"
#include "mfot/smr_feature.hpp"

namespace mfot::test {

inline float uniform01(std::mt19937_64& rng) { return static_cast<float>(rng() >> 40) * 0x1.0p-24f; }

inline float gaussian(std::mt19937_64& rng) {
  const float u1 = std::max(uniform01(rng), 1e-7f);
  const float u2 = uniform01(rng);
  return std::sqrt(-2.f * std::log(u1)) * std::cos(6.2831853f * u2);
}

inline Rgb8 random_color(std::mt19937_64& rng) {
  return {static_cast<std::uint8_t>(rng() & 0xff), static_cast<std::uint8_t>((rng() >> 8) & 0xff),
          static_cast<std::uint8_t>((rng() >> 16) & 0xff)};
}

inline Pose perturbed(const Pose& pose, float sigma_t, float sigma_r, std::mt19937_64& rng) {
  Pose p = pose;
  p.translation += sigma_t * Eigen::Vector3f(gaussian(rng), gaussian(rng), gaussian(rng));
  const Eigen::Vector3f w = sigma_r * Eigen::Vector3f(gaussian(rng), gaussian(rng), gaussian(rng));
  if (w.norm() > 0.f)
    p.rotation = (Eigen::Quaternionf(Eigen::AngleAxisf(w.norm(), w.normalized())) * p.rotation).normalized();
  return p;
}

struct RandomScene {
  ObjectModel model;
  HypothesisData data;
  Pose truth;
  std::vector<Pose> particles;
};

// model_points in a box of `extent` metres around the origin; data_points of which 80 % are
// model points seen at the true pose with 1 mm noise and 20 % random points around the object
// (some outside the grid); particles spread by sigma_t metres and sigma_r radians.
inline RandomScene random_scene(std::size_t model_points, std::size_t data_points, std::size_t particles, float sigma_t,
                                float sigma_r, std::uint64_t seed, float extent = 0.12f) {
  std::mt19937_64 rng(seed);
  RandomScene scene;
  for (std::size_t i = 0; i < model_points; ++i) {
    const Eigen::Vector3f p(extent * (uniform01(rng) - 0.5f), 0.8f * extent * (uniform01(rng) - 0.5f),
                            0.6f * extent * (uniform01(rng) - 0.5f));
    scene.model.cloud.push_back(p, random_color(rng));
  }
  scene.model.features = compute_smr(scene.model.cloud.colors);
  scene.truth.translation = Eigen::Vector3f(0.1f, -0.05f, 0.9f);
  scene.truth.rotation = Eigen::Quaternionf(Eigen::AngleAxisf(0.7f, Eigen::Vector3f(0.3f, 1.f, 0.2f).normalized()));
  const Eigen::Isometry3f to_camera = scene.truth.isometry();
  std::vector<Rgb8> colors;
  for (std::size_t j = 0; j < data_points; ++j) {
    Eigen::Vector3f z;
    Rgb8 c;
    if (model_points > 0 && uniform01(rng) < 0.8f) {
      const std::size_t k = rng() % model_points;
      z = to_camera * scene.model.cloud.positions[k] +
          0.001f * Eigen::Vector3f(gaussian(rng), gaussian(rng), gaussian(rng));
      c = scene.model.cloud.colors[k];
    } else {
      z = scene.truth.translation +
          2.f * extent * Eigen::Vector3f(uniform01(rng) - 0.5f, uniform01(rng) - 0.5f, uniform01(rng) - 0.5f);
      c = random_color(rng);
    }
    scene.data.points.push_back(z);
    colors.push_back(c);
  }
  scene.data.colors = colors;
  scene.data.features = compute_smr(colors);
  for (std::size_t i = 0; i < particles; ++i) scene.particles.push_back(perturbed(scene.truth, sigma_t, sigma_r, rng));
  return scene;
}

}  // namespace mfot::test
