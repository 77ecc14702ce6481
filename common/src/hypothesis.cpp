// Hypothesis-data selection, thesis 3.3 (steps in the header).

#include "mfot/hypothesis.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace mfot {

Eigen::AlignedBox3f model_bounding_box(const ObjectModel& model) {
  Eigen::AlignedBox3f box;  // default-constructed: empty
  for (const Eigen::Vector3f& p : model.cloud.positions) box.extend(p);
  return box;
}

namespace {
// Calls keep(k) for every scene point k inside the grown box at last_estimate (steps in the header).
template <class Keep>
void select_inside(const ColoredCloud& scene, const Eigen::AlignedBox3f& model_box, const Pose& last_estimate,
                   const HypothesisOptions& options, Keep&& keep) {
  if (!(std::isfinite(options.margin) && options.margin >= 0.f && options.margin <= 1.f)) {
    throw std::invalid_argument("HypothesisOptions.margin must be in [0, 1] metres, got " +
                                std::to_string(options.margin));
  }
  if (scene.colors.size() != scene.positions.size()) {
    throw std::invalid_argument("select_hypothesis_data: scene positions and colors differ in length");
  }
  if (model_box.isEmpty()) return;
  const Eigen::Vector3f lo = model_box.min() - Eigen::Vector3f::Constant(options.margin);
  const Eigen::Vector3f hi = model_box.max() + Eigen::Vector3f::Constant(options.margin);
  const Eigen::Matrix3f rt = last_estimate.rotation.toRotationMatrix().transpose();
  const Eigen::Vector3f offset = -(rt * last_estimate.translation);
  for (std::size_t k = 0; k < scene.size(); ++k) {
    const Eigen::Vector3f q = rt * scene.positions[k] + offset;
    if ((q.array() >= lo.array()).all() && (q.array() <= hi.array()).all()) keep(k);
  }
}
}  // namespace

void select_hypothesis_data(const ColoredCloud& scene, std::span<const SmrFeature> scene_features,
                            const Eigen::AlignedBox3f& model_box, const Pose& last_estimate,
                            const HypothesisOptions& options, HypothesisData& out) {
  if (scene_features.size() != scene.size()) {
    throw std::invalid_argument("select_hypothesis_data: scene positions, colors and features differ in length");
  }
  out.points.clear();
  out.features.clear();
  out.colors.clear();
  select_inside(scene, model_box, last_estimate, options, [&](std::size_t k) {
    out.points.push_back(scene.positions[k]);
    out.features.push_back(scene_features[k]);
    out.colors.push_back(scene.colors[k]);
  });
}

void select_hypothesis_points(const ColoredCloud& scene, const Eigen::AlignedBox3f& model_box,
                              const Pose& last_estimate, const HypothesisOptions& options, HypothesisData& out) {
  out.points.clear();
  out.features.clear();
  out.colors.clear();
  select_inside(scene, model_box, last_estimate, options, [&](std::size_t k) {
    out.points.push_back(scene.positions[k]);
    out.colors.push_back(scene.colors[k]);
  });
}

void select_hypothesis_data(const ColoredCloud& scene, std::span<const SmrFeature> scene_features,
                            const ObjectModel& model, const Pose& last_estimate, const HypothesisOptions& options,
                            HypothesisData& out) {
  select_hypothesis_data(scene, scene_features, model_bounding_box(model), last_estimate, options, out);
}

}  // namespace mfot
