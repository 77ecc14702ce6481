#pragma once
// Hypothesis-data selection, thesis 3.3: the points of Z_t near the last estimate X_{t-1} (x) M_{t-1}.

#include <Eigen/Geometry>

#include "mfot/likelihood.hpp"

namespace mfot {

struct HypothesisOptions {
  // m, added on every side of the model's bounding box: the largest motion expected between two
  // frames plus sensor noise. Must be finite and in [0, 1].
  float margin = 0.05f;
};

// Axis-aligned bounding box of the model's points in the object frame (empty box for no points).
Eigen::AlignedBox3f model_bounding_box(const ObjectModel& model);

// Selects the scene points inside the model's object-frame bounding box, grown by
// options.margin, placed at last_estimate (an oriented box in the camera frame). Steps: move each
// scene point into the object frame with the inverse of last_estimate; keep it when it lies in
// the grown box; copy its position (camera frame), SMR feature and colour into out. out is
// cleared first and its capacity reused. scene_features must match scene in length.
void select_hypothesis_data(const ColoredCloud& scene, std::span<const SmrFeature> scene_features,
                            const Eigen::AlignedBox3f& model_box, const Pose& last_estimate,
                            const HypothesisOptions& options, HypothesisData& out);

// The same selection without features: positions and colours only, out.features left empty. A
// tracker computes the SMR features (per point) of the points it keeps, not of the whole scene.
void select_hypothesis_points(const ColoredCloud& scene, const Eigen::AlignedBox3f& model_box,
                              const Pose& last_estimate, const HypothesisOptions& options, HypothesisData& out);

// Convenience overload computing the model's bounding box.
void select_hypothesis_data(const ColoredCloud& scene, std::span<const SmrFeature> scene_features,
                            const ObjectModel& model, const Pose& last_estimate, const HypothesisOptions& options,
                            HypothesisData& out);

}  // namespace mfot
