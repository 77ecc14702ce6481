// The [CC13] point-to-point likelihood, thesis 2.3.2, equations 2.18 to 2.21 (steps in the header).

#include "mfot/point_to_point_likelihood.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace mfot {
namespace {

const PointToPointOptions& validated(const PointToPointOptions& options) {
  if (!(std::isfinite(options.lambda_e) && options.lambda_e >= 0.f)) {
    throw std::invalid_argument("PointToPointOptions.lambda_e must be finite and >= 0, got " +
                                std::to_string(options.lambda_e));
  }
  if (!(std::isfinite(options.lambda_c) && options.lambda_c >= 0.f)) {
    throw std::invalid_argument("PointToPointOptions.lambda_c must be finite and >= 0, got " +
                                std::to_string(options.lambda_c));
  }
  if (!(options.max_distance > 0.f && options.max_distance <= 1.f)) {
    throw std::invalid_argument("PointToPointOptions.max_distance must be in (0, 1] metres, got " +
                                std::to_string(options.max_distance));
  }
  return options;
}

std::array<float, 3> unit_rgb(Rgb8 c) { return {c.r / 255.f, c.g / 255.f, c.b / 255.f}; }

}  // namespace

PointToPointLikelihood::PointToPointLikelihood(const PointToPointOptions& options)
    : options_(validated(options)), model_index_(options.max_distance) {}

void PointToPointLikelihood::set_model(const ObjectModel& model) {
  if (model.cloud.colors.size() != model.cloud.positions.size()) {
    throw std::invalid_argument("PointToPointLikelihood::set_model: cloud colors and positions differ in length");
  }
  model_index_.build(model.cloud.positions);
  model_colors_.resize(model.cloud.size());
  for (std::size_t k = 0; k < model.cloud.size(); ++k) model_colors_[k] = unit_rgb(model.cloud.colors[k]);
}

void PointToPointLikelihood::evaluate(std::span<const Pose> particles, const HypothesisData& data,
                                      std::span<float> scores) {
  if (scores.size() != particles.size()) {
    throw std::invalid_argument("PointToPointLikelihood::evaluate: scores.size() != particles.size()");
  }
  if (data.colors.size() != data.points.size()) {
    throw std::invalid_argument("PointToPointLikelihood::evaluate: data.colors.size() != data.points.size()");
  }
  data_colors_.resize(data.colors.size());
  for (std::size_t j = 0; j < data.colors.size(); ++j) data_colors_[j] = unit_rgb(data.colors[j]);

  for (std::size_t i = 0; i < particles.size(); ++i) {
    const Eigen::Matrix3f rt = particles[i].rotation.toRotationMatrix().transpose();
    const Eigen::Vector3f offset = -(rt * particles[i].translation);
    double score = 0.0;
    for (std::size_t j = 0; j < data.points.size(); ++j) {
      const Eigen::Vector3f q = rt * data.points[j] + offset;
      float squared = 0.f;
      const int m = model_index_.nearest(q, options_.max_distance, &squared);
      if (m < 0) continue;
      const std::array<float, 3>& cm = model_colors_[static_cast<std::size_t>(m)];
      const std::array<float, 3>& cz = data_colors_[j];
      const float dr = cm[0] - cz[0], dg = cm[1] - cz[1], db = cm[2] - cz[2];
      const float d_e = std::sqrt(squared);                                   // 2.19
      const float d_c = std::sqrt(dr * dr + dg * dg + db * db);               // 2.21
      score += std::exp(-options_.lambda_e * d_e - options_.lambda_c * d_c);  // 2.18
    }
    scores[i] = static_cast<float>(score);
  }
}

}  // namespace mfot
