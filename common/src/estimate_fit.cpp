// How well an estimate explains the scene points it claims (steps in the header).

#include "mfot/estimate_fit.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace mfot {

namespace {

const EstimateFitOptions& validated(const EstimateFitOptions& options) {
  options.validate();
  return options;
}

// Cosine between two SMR vectors (non-negative entries: in [0, 1]); 0 when either is all zero.
float colour_agreement(const SmrFeature& a, const SmrFeature& b) {
  const std::array<float, kSmrBins> u = a.dense(), v = b.dense();
  float dot = 0.f, uu = 0.f, vv = 0.f;
  for (int c = 0; c < kSmrBins; ++c) {
    dot += u[c] * v[c];
    uu += u[c] * u[c];
    vv += v[c] * v[c];
  }
  return uu > 0.f && vv > 0.f ? dot / std::sqrt(uu * vv) : 0.f;
}

}  // namespace

void EstimateFitOptions::validate() const {
  if (!(match_distance > 0.f && match_distance <= 0.1f)) {
    throw std::invalid_argument("EstimateFitOptions.match_distance must be in (0, 0.1] metres, got " +
                                std::to_string(match_distance));
  }
  if (!(claim_margin >= 0.f && claim_margin <= 0.1f)) {
    throw std::invalid_argument("EstimateFitOptions.claim_margin must be in [0, 0.1] metres, got " +
                                std::to_string(claim_margin));
  }
  if (!(min_claimed_points >= 1 && min_claimed_points <= 1000000)) {
    throw std::invalid_argument("EstimateFitOptions.min_claimed_points must be in [1, 1000000], got " +
                                std::to_string(min_claimed_points));
  }
}

// Cells of twice the match distance: a query visits at most 8 cells.
EstimateFit::EstimateFit(const EstimateFitOptions& options)
    : options_(validated(options)), model_hash_(2.f * options.match_distance) {}

float EstimateFit::fit(const HypothesisData& data, const ObjectModel& model, const Eigen::AlignedBox3f& model_box,
                       const Pose& estimate) {
  if (data.features.size() != data.points.size()) {
    throw std::invalid_argument("EstimateFit::fit: hypothesis data needs one SMR feature per point (" +
                                std::to_string(data.points.size()) + " points, " +
                                std::to_string(data.features.size()) + " features)");
  }
  if (model.features.size() != model.cloud.positions.size()) {
    throw std::invalid_argument("EstimateFit::fit: the model needs one SMR feature per point");
  }
  claimed_ = 0;
  if (model_box.isEmpty()) return 0.f;
  Eigen::AlignedBox3f claim = model_box;
  claim.min().array() -= options_.claim_margin;
  claim.max().array() += options_.claim_margin;
  const Eigen::Matrix3f to_object = estimate.rotation.conjugate().toRotationMatrix();
  claimed_local_.clear();
  claimed_index_.clear();
  for (std::size_t i = 0; i < data.points.size(); ++i) {
    const Eigen::Vector3f local = to_object * (data.points[i] - estimate.translation);
    if (!claim.contains(local)) continue;
    claimed_local_.push_back(local);
    claimed_index_.push_back(i);
  }
  claimed_ = claimed_local_.size();
  if (claimed_ < static_cast<std::size_t>(options_.min_claimed_points)) return 0.f;
  // An even sample of at most kScoredPoints: the mean moves by well under 0.01 and the cost stays
  // a small share of the filter step's.
  const std::size_t scored_max = static_cast<std::size_t>(kScoredPoints);
  const std::size_t stride = (claimed_ + scored_max - 1) / scored_max;
  model_hash_.build(model.cloud.positions);
  double total = 0.0;
  std::size_t scored = 0;
  for (std::size_t k = 0; k < claimed_; k += stride, ++scored) {
    const int nearest = model_hash_.nearest(claimed_local_[k], options_.match_distance);
    if (nearest >= 0) {
      total += colour_agreement(data.features[claimed_index_[k]], model.features[static_cast<std::size_t>(nearest)]);
    }
  }
  return static_cast<float>(total / static_cast<double>(scored));
}

}  // namespace mfot
