#pragma once
// The hypothesis-evaluation interface shared by every likelihood backend (thesis 3.3 for JCSD,
// 2.3.2 / equations 2.18-2.21 for the point-to-point baseline of [CC13]).

#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "mfot/smr_feature.hpp"
#include "mfot/types.hpp"

namespace mfot {

// An object model: coloured points in the object frame and their SMR features.
struct ObjectModel {
  ColoredCloud cloud;                // object frame, metres
  std::vector<SmrFeature> features;  // one per point
};

// Hypothesis data Z' (thesis 3.3): the scene points near the last estimate, camera frame.
struct HypothesisData {
  std::vector<Eigen::Vector3f> points;  // camera frame, metres
  std::vector<SmrFeature> features;     // one per point
  std::vector<Rgb8> colors;             // one per point (used by the point-to-point baseline)
};

// Scores particles: scores[i] is the raw, unnormalised score s_i of particles[i] (higher is
// better; 3.20 for JCSD). Normalisation into weights (3.21) is the particle filter's job.
class Likelihood {
 public:
  virtual ~Likelihood() = default;
  virtual std::string_view name() const = 0;
  // Replaces the model (object frame); builds whatever the backend needs (grid, k-d tree, upload).
  virtual void set_model(const ObjectModel& model) = 0;
  // particles: object->camera poses. scores.size() == particles.size().
  virtual void evaluate(std::span<const Pose> particles, const HypothesisData& data, std::span<float> scores) = 0;
};

// Likelihood weights from raw particle scores, equation 3.21:
//   p_i proportional to exp(-lambda * (1 - (s_i - s_min) / (s_max - s_min))),
// normalised to sum 1. When s_max == s_min (no particle is better than another) the weights are
// uniform. lambda must be finite and > 0 (std::invalid_argument otherwise); weights.size() must
// equal scores.size(). Non-finite scores are treated as s_min.
void likelihood_weights(std::span<const float> scores, float lambda, std::span<float> weights);

}  // namespace mfot
