#pragma once
// The [CC13] point-to-point likelihood used as the baseline, thesis 2.3.2, equations 2.18 to 2.21.

#include <array>

#include "mfot/likelihood.hpp"
#include "mfot/spatial_hash.hpp"

namespace mfot {

struct PointToPointOptions {
  float lambda_e = 200.f;      // 1/m, spatial sensitivity of 2.18 (exp(-200 * 5 mm) = 0.37)
  float lambda_c = 2.f;        // colour sensitivity of 2.18, per unit of RGB distance
  float max_distance = 0.01f;  // m, correspondence search radius; farther points contribute 0
};

// Baseline hypothesis evaluation of [CC13] (thesis 2.3.2). Steps per particle:
//  1. move every hypothesis point z into the object frame with the inverse particle pose;
//  2. find its nearest model point m within max_distance (SpatialHash, built by set_model);
//  3. add exp(-lambda_e d_e) exp(-lambda_c d_c), with d_e = |m - z| (2.19) and d_c the Euclidean
//     distance of the RGB colours scaled to [0, 1] (2.21, range [0, sqrt 3]).
// The normal term of 2.18/2.20 is left out: the frames carry no normals (it would be a factor
// of 1 for every pair with equal normals). Points without a correspondence contribute 0.
class PointToPointLikelihood final : public Likelihood {
 public:
  // Throws std::invalid_argument unless lambda_e and lambda_c are finite and >= 0 and
  // max_distance is in (0, 1] m.
  explicit PointToPointLikelihood(const PointToPointOptions& options = {});
  PointToPointLikelihood(const PointToPointLikelihood&) = delete;
  PointToPointLikelihood& operator=(const PointToPointLikelihood&) = delete;

  std::string_view name() const override { return "point-to-point"; }
  void set_model(const ObjectModel& model) override;
  void evaluate(std::span<const Pose> particles, const HypothesisData& data, std::span<float> scores) override;

 private:
  PointToPointOptions options_;
  SpatialHash model_index_;
  std::vector<std::array<float, 3>> model_colors_;  // RGB in [0, 1]
  std::vector<std::array<float, 3>> data_colors_;   // per evaluate call, RGB in [0, 1]
};

}  // namespace mfot
