#pragma once
// Sampling Importance Resampling particle filter over SE(3), thesis 2.2.2 (equations 2.11 to
// 2.15, Algorithm 1) and 3.1, with the likelihood weights of equation 3.21.

#include <cstdint>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "mfot/likelihood.hpp"

namespace mfot {

enum class ResamplingScheme {
  kMultinomial,  // Algorithm 1: N independent uniform draws, binary search in the CDF
  kSystematic,   // one uniform offset, N evenly spaced draws: same expectation, lower variance
};

// How hard one step follows the object's motion: the two settings of ParticleFilterOptions that a
// caller may change from frame to frame (TrackingStep follows an isolated object harder).
struct StepMotion {
  float predicted_fraction = 0.5f;  // share of resampled particles moved by dX (2.15); [0, 1]
  int refine_rounds = 0;            // pattern-search rounds on the estimate (step 6); [0, 20]
  // Throws std::invalid_argument naming the field as owner.field.
  void validate(const std::string& owner = "StepMotion") const;
};

// Defaults other than num_particles and predicted_fraction come from the synthetic tracking test
// (tests/core/test_particle_filter.cpp): 3 mm / 1 degree diffusion keeps a 2 cm + 10 degree per
// frame motion captured once dX is known, and a sharp lambda keeps the weighted mean precise.
// Member defaults: the thesis's values, for library users and unit tests; the services and
// mfot-inprocess fill every field from configs/default.yaml and the method's constants (docs/method.md).
struct ParticleFilterOptions {
  int num_particles = 200;  // [1, 1000000]; the thesis runs 100 to 200
  // Standard deviations of C_init (2.12) over (x, y, z, roll, pitch, yaw): metres, radians; >= 0.
  PoseVector init_sigma = (PoseVector() << 0.003f, 0.003f, 0.003f, 0.0175f, 0.0175f, 0.0175f).finished();
  float a = 0.02f;      // weight of dX dX^T in C_t = a dX dX^T + b C_init (2.14); finite, >= 0
  float b = 1.f;        // weight of C_init in C_t (2.14); finite, >= 0
  float lambda = 80.f;  // sharpness of the likelihood weights (3.21); in (0, 1000]
  ResamplingScheme resampling = ResamplingScheme::kSystematic;
  float predicted_fraction = 0.5f;  // share of resampled particles moved by dX (2.15); [0, 1]
  // In a step given a companion's motion (an object touching this one moved: the hand gripping it),
  // this share of the particles that dX leaves unpredicted is moved by that motion instead
  // (departure from the thesis: a gripped object turns with its gripper, whose estimate has
  // already caught up with the turn while this object's own dX still lags it). [0, 1]; 0 = the thesis.
  float companion_fraction = 0.f;
  std::uint64_t seed = 1;  // seeds the filter's own std::mt19937_64
  // replace_estimate also moves the whole particle set rigidly by this share of the correction (the
  // translation's share, the rotation slerped as far), so the next step starts nearer where the caller's
  // refinement (ICP) put the object (departure from the thesis, whose set only ever moves by its own
  // steps). Left behind, the set stays on the likelihood's own mode, which on a weakly shaped object
  // such as a hand lies degrees off the surface fit, and the caller pulls the estimate back every frame
  // until the gap passes its largest correction; moved all the way, nothing holds the set against the
  // refinement's own creep. [0, 1]; 0 = the set stays (thesis).
  float follow_replaced_estimate = 0.f;
  // The first steps of the pattern search of a step whose StepMotion asks for refine_rounds (step 6): it
  // tries the estimate moved by +-refine_translation along each axis and turned by +-refine_rotation
  // about each axis (12 hypotheses and the estimate itself per round), moves to the best and halves both
  // steps.
  float refine_translation = 0.002f;  // metres, [0, 0.1]
  float refine_rotation = 0.0175f;    // radians, [0, 0.5]
  // The filter's own step motion (what step() without a StepMotion uses): the thesis's, the weighted
  // mean only (no refinement rounds).
  StepMotion step_motion() const { return {predicted_fraction, 0}; }
};

// Pose increments in the 6-vector (x, y, z, roll, pitch, yaw). The rotation part is a rotation
// applied in the camera frame about the object's origin: R' = R_inc R with
// R_inc = Rz(yaw) Ry(pitch) Rx(roll). Increments compose rotations, never add Euler angles.
Eigen::Quaternionf rotation_from_rpy(const Eigen::Vector3f& rpy);
Eigen::Vector3f rpy_from_rotation(
    const Eigen::Quaternionf& rotation);  // roll, yaw in [-pi, pi], pitch in [-pi/2, pi/2]
// dX = X_to - X_from (2.13): translation difference and the rpy of R_to R_from^T.
PoseVector pose_difference(const Pose& from, const Pose& to);
// X + dX: translation added, rotation composed on the left (inverse of pose_difference).
Pose apply_increment(const Pose& pose, const PoseVector& increment);
// The 13 poses of one pattern-search round about centre: out[0] = centre, then centre moved by
// +-translation along (k = 0..2) and turned by +-rotation about (k = 3..5) each camera axis, as
// out[1 + 2 k] (+) and out[2 + 2 k] (-), with apply_increment.
inline constexpr std::size_t kPatternMoves = 13;
void pattern_moves(const Pose& centre, float translation, float rotation, std::span<Pose, kPatternMoves> out);

// Weighted mean pose (2.11): weighted mean translation and the weighted quaternion mean, the
// eigenvector of the largest eigenvalue of sum w_i q_i q_i^T (invariant to each q_i's sign),
// returned with the sign closer to `reference`. Weights need not be normalised; sizes must match.
Pose weighted_pose_mean(std::span<const Pose> poses, std::span<const float> weights,
                        const Eigen::Quaternionf& reference = Eigen::Quaternionf::Identity());

// SIR particle filter tracking one object's pose (thesis 2.2.2, 3.1). Steps of step():
//  1. resample from the previous step's weights (multinomial per Algorithm 1, or systematic);
//  2. diffuse every drawn state with N(0, C_t), C_t = a dX dX^T + b C_init (2.14), sampled as
//     sqrt(a) dX n0 + sqrt(b) sigma_init .* n with n0 ~ N(0, 1), n ~ N(0, I6);
//  3. predict (2.15): add dX to predicted_fraction of the particles, spread evenly over the set;
//     given a companion's motion, add it to companion_fraction of the others (spread evenly over
//     them; their diffusion's dX term uses the companion's motion);
//  4. evaluate the particles with the likelihood (3.20) and weight them with 3.21;
//  5. estimate (2.11): weighted mean translation and the weighted quaternion mean (eigenvector of
//     the largest eigenvalue of sum w_i q_i q_i^T, sign-aligned with the previous estimate);
//     dX = X_t - X_{t-1} (2.13);
//  6. with a StepMotion's refine_rounds > 0, refine the estimate by a pattern search on the likelihood before
//     dX is taken (departure: the weighted mean of 100 particles over 6 DoF lags a turning object;
//     the refined estimate's dX then predicts the next frame's particles further).
// The first step after reset() skips 1-3: the particles were just drawn from N(X_init, C_init)
// (2.12). Deterministic for a given seed and call sequence; step() allocates nothing once reset()
// has sized the buffers. Non-copyable: it owns the particle buffers and its generator.
class ParticleFilter {
 public:
  // Throws std::invalid_argument naming the offending field.
  explicit ParticleFilter(const ParticleFilterOptions& options = {});
  ParticleFilter(const ParticleFilter&) = delete;
  ParticleFilter& operator=(const ParticleFilter&) = delete;

  // Draws the particles from N(pose, C_init) with equal weights, zero velocity (2.12). The
  // generator is not reseeded: it continues its sequence.
  void reset(const Pose& pose);
  bool initialised() const { return initialised_; }

  // One filter iteration (steps above); returns the new estimate. Throws std::logic_error before
  // the first reset().
  const Pose& step(const HypothesisData& data, Likelihood& likelihood);
  // The same with this frame's predicted_fraction and refine_rounds in place of the options' (predicted_fraction,
  // no refinement) (validated: throws std::invalid_argument).
  const Pose& step(const HypothesisData& data, Likelihood& likelihood, const StepMotion& motion);
  // The same with a companion's motion: the increment (as dX, applied with apply_increment) that
  // moving with a touching object would give this object; companion_fraction of the particles that
  // dX leaves unpredicted are moved by it (step 3). nullptr = none.
  const Pose& step(const HypothesisData& data, Likelihood& likelihood, const StepMotion& motion,
                   const PoseVector* companion);
  // A frame whose data cannot show the object (hidden behind nearer surfaces; the caller
  // decides, e.g. with OcclusionTest): no step, the estimate stays and dX becomes 0, since the
  // hidden motion is unknown and the last one would carry the particles off. The particles and
  // their weights stay for the next step(). Departure from the thesis, whose filter always steps
  // (and then follows whatever occludes the object). Throws std::logic_error before reset().
  const Pose& hold();
  // Puts a refined pose in place of the last step's estimate (a caller's own refinement, e.g.
  // IcpRefinement) and takes dX from it, so the next prediction follows the refined motion; the
  // particle set moves rigidly by follow_replaced_estimate of the correction (the weights kept). Throws
  // std::logic_error unless the last call was step().
  const Pose& replace_estimate(const Pose& pose);
  // Moves the whole particle set rigidly so that the estimate becomes `pose` (a hidden object
  // carried by another: CarryMonitor), with dX the move, so the next step predicts it onwards. The
  // weights stay. Throws std::logic_error before reset().
  const Pose& move_to(const Pose& pose);

  const Pose& estimate() const { return estimate_; }
  // dX of the last step (2.13), (x, y, z, roll, pitch, yaw) per frame.
  const PoseVector& velocity() const { return velocity_; }
  std::span<const Pose> particles() const { return particles_; }
  std::span<const float> weights() const { return weights_; }  // normalised, sum 1
  std::span<const float> scores() const { return scores_; }    // raw s_i of the last step
  // 1 / sum w_i^2 of the current weights, in [1, N].
  float effective_sample_size() const;
  const ParticleFilterOptions& options() const { return options_; }

 private:
  double uniform01();
  float standard_normal();
  void resample();
  void diffuse_and_predict(float predicted_fraction, const PoseVector* companion);
  void move_particles(const Pose& pose);  // every particle by the rigid motion taking the estimate to pose
  void refine(const HypothesisData& data, Likelihood& likelihood, int rounds);

  ParticleFilterOptions options_;
  std::mt19937_64 rng_;
  bool has_spare_normal_ = false;
  float spare_normal_ = 0.f;
  bool initialised_ = false;
  bool resample_pending_ = false;
  std::vector<Pose> particles_;
  std::vector<Pose> drawn_;
  std::vector<float> weights_;
  std::vector<float> scores_;
  std::vector<double> cdf_;
  std::vector<Pose> candidates_;
  std::vector<float> candidate_scores_;
  Pose estimate_;
  Pose previous_estimate_;     // the estimate before the last step, for replace_estimate
  bool stepped_last_ = false;  // the last call was step()
  PoseVector velocity_ = PoseVector::Zero();
};

}  // namespace mfot
