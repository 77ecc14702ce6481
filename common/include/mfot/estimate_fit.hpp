#pragma once
// How well an estimated pose explains the scene points it claims: mfot's published confidence
// (a departure: the thesis publishes none, and the particle weights of 3.21 are normalised between
// the best and the worst particle of the frame, so they look the same whether the best is right or
// wrong). Scored like the segmentation of thesis 3.4 (a scene point is explained by a model point
// within a distance), with the colour of the SMR feature (3.2.1) on top, so a box turned onto
// another face of the same outline is not explained either.

#include <Eigen/Geometry>
#include <vector>

#include "mfot/likelihood.hpp"
#include "mfot/spatial_hash.hpp"

namespace mfot {

// Member defaults: for library users and unit tests; the services fill every field from
// configs/default.yaml (tracker.confidence_*).
struct EstimateFitOptions {
  // A claimed scene point with a model point this close (object frame, metres) is explained
  // geometrically; (0, 0.1].
  float match_distance = 0.01f;
  // Scene points inside the model's bounding box grown by this (metres) are claimed by the
  // estimate; [0, 0.1].
  float claim_margin = 0.01f;
  // With fewer claimed points there is nothing to judge: the fit is 0. [1, 1000000].
  int min_claimed_points = 20;
  void validate() const;  // throws std::invalid_argument naming the field
};

// Steps of fit():
//  1. build a spatial hash over the model's points (object frame);
//  2. map every hypothesis point into the object frame with the inverse of the estimate and keep
//     those inside the model's bounding box grown by claim_margin (the points the estimate says
//     are the object's surface);
//  3. score an even sample of at most 400 claimed points (all of a small object): the cosine between
//     a point's SMR vector and that of the nearest model point within match_distance, 0 without one;
//  4. the fit is the mean score over the sample, in [0, 1]; 0 with fewer than min_claimed_points
//     claimed points.
// A right estimate scores near the colour agreement of its model (about 0.8-0.95); a turned one
// leaves its claimed points off the model's surface or on faces of other colours. Deterministic,
// no random draws. Non-copyable: it owns the model hash, rebuilt per call (models change between
// frames) and the claimed points' buffers.
class EstimateFit {
 public:
  // At most this many claimed points are scored (step 3).
  static constexpr int kScoredPoints = 400;

  explicit EstimateFit(const EstimateFitOptions& options = {});
  EstimateFit(const EstimateFit&) = delete;
  EstimateFit& operator=(const EstimateFit&) = delete;

  const EstimateFitOptions& options() const { return options_; }

  // data: camera frame with SMR features (data.features.size() == data.points.size(), else
  // std::invalid_argument); model_box: model_bounding_box(model); estimate: object -> camera.
  float fit(const HypothesisData& data, const ObjectModel& model, const Eigen::AlignedBox3f& model_box,
            const Pose& estimate);
  // Points claimed by the last fit() (its mean is over an even sample of them).
  std::size_t claimed_points() const { return claimed_; }

 private:
  EstimateFitOptions options_;
  SpatialHash model_hash_;
  std::vector<Eigen::Vector3f> claimed_local_;  // claimed points, object frame
  std::vector<std::size_t> claimed_index_;      // their indices in the data
  std::size_t claimed_ = 0;
};

}  // namespace mfot
