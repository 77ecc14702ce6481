#pragma once
// Global registration of a known object model on points that show the object again: the pose of a
// re-identified object's remembered model on its new cluster, so that the object keeps its frame
// (its published pose goes on where it left off instead of starting over from a new model's frame).
// A departure from the thesis, which has no re-identification. The score is the JCSD likelihood
// (thesis 3.3, equations 3.18 to 3.20) that tracks the object; the check is EstimateFit.

#include <cstdint>
#include <optional>
#include <vector>

#include "mfot/estimate_fit.hpp"
#include "mfot/jcsd_likelihood.hpp"
#include "mfot/likelihood.hpp"

namespace mfot {

// Member defaults: for library users and unit tests; the merger fills every field from
// configs/default.yaml (merger.reidentify_*).
struct ModelRegistrationOptions {
  int rotations = 256;       // coarse rotation hypotheses, drawn uniformly over SO(3) once [1, 100000]
  int candidates = 4;        // best coarse hypotheses refined [1, 64]
  int refine_rounds = 16;    // pattern-search rounds per candidate [0, 100]
  float min_fit = 0.7f;      // EstimateFit the registered pose needs; below it there is none [0, 1]
  float cell_size = 0.015f;  // JCSD grid cell = kernel bandwidth, metres (tracker.cell_size) [0.001, 0.2]
  EstimateFitOptions fit;
  std::uint64_t seed = 1;  // the rotation hypotheses' generator
  void validate() const;   // throws std::invalid_argument naming the field
};

struct Registration {
  Pose pose;        // model (object frame) -> camera
  float fit = 0.f;  // EstimateFit of pose on the points
};

// Steps of register_model():
//  1. coarse hypotheses: every rotation of the fixed set (the prior rotation first, when given),
//     placed so that the centroid of the model's near side under it (an orthographic z-buffer
//     along the line of sight, cells and depth of match_distance) lies on the
//     points' centroid (the points show the object's near side only), then moved by three
//     translation-only ICP steps (about 256 of the points, nearest model points within 3 cm);
//  2. score them all with the model's JCSD grid on the points (3.20);
//  3. refine the best `candidates` by a pattern search on the same score: the pose moved by +-1 cm
//     along and turned by +-8 deg about each camera axis (a turn followed by one ICP step), the
//     best move kept, both steps halved when none is better;
//  4. the refined pose with the highest score is the registration when its EstimateFit reaches
//     min_fit; otherwise there is none (another object, or too little of it in view).
// Deterministic: the rotation set comes from the seed once. Non-copyable: it owns the likelihood.
class ModelRegistration {
 public:
  explicit ModelRegistration(const ModelRegistrationOptions& options = {});
  ModelRegistration(const ModelRegistration&) = delete;
  ModelRegistration& operator=(const ModelRegistration&) = delete;

  const ModelRegistrationOptions& options() const { return options_; }

  // points: camera frame with SMR features (one per point). prior: a rotation to try first (the
  // object's last pose), or none.
  std::optional<Registration> register_model(const ObjectModel& model, const HypothesisData& points,
                                             const std::optional<Eigen::Quaternionf>& prior = std::nullopt);
  // The model's JCSD grid lives only during register_model: empty between calls.
  const JcsdGrid& grid() const { return likelihood_.grid(); }

 private:
  // Translation-only ICP: moves pose by the mean offset of about 256 of the points from their
  // nearest model points within 3 cm, iterations times.
  void align_translation(const ObjectModel& model, const HypothesisData& points, int iterations, Pose& pose) const;

  ModelRegistrationOptions options_;
  std::vector<Eigen::Quaternionf> rotations_;
  JcsdLikelihood likelihood_;
  EstimateFit fit_;
  std::vector<Pose> hypotheses_;
  // Per cell across the line of sight (a square grid about the model's origin): the nearest model
  // point's depth.
  std::vector<float> nearest_;
  std::vector<Eigen::Vector3f> turned_;  // the model's points under one rotation hypothesis
  SpatialHash align_hash_;               // the model's points, object frame
  std::vector<float> scores_;
};

}  // namespace mfot
