// SIR particle filter over SE(3), thesis 2.2.2 and 3.1 (steps in the header).

#include "mfot/particle_filter.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace mfot {
namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("ParticleFilterOptions." + what);
}

const ParticleFilterOptions& validated(const ParticleFilterOptions& o) {
  require(o.num_particles >= 1 && o.num_particles <= 1000000,
          "num_particles must be in [1, 1000000], got " + std::to_string(o.num_particles));
  for (int k = 0; k < 6; ++k) {
    require(std::isfinite(o.init_sigma[k]) && o.init_sigma[k] >= 0.f,
            "init_sigma[" + std::to_string(k) + "] must be finite and >= 0, got " + std::to_string(o.init_sigma[k]));
  }
  require(std::isfinite(o.a) && o.a >= 0.f, "a must be finite and >= 0, got " + std::to_string(o.a));
  require(std::isfinite(o.b) && o.b >= 0.f, "b must be finite and >= 0, got " + std::to_string(o.b));
  require(o.lambda > 0.f && o.lambda <= 1000.f, "lambda must be in (0, 1000], got " + std::to_string(o.lambda));
  require(o.resampling == ResamplingScheme::kMultinomial || o.resampling == ResamplingScheme::kSystematic,
          "resampling must be kMultinomial or kSystematic");
  o.step_motion().validate("ParticleFilterOptions");
  require(o.follow_replaced_estimate >= 0.f && o.follow_replaced_estimate <= 1.f,
          "follow_replaced_estimate must be in [0, 1], got " + std::to_string(o.follow_replaced_estimate));
  require(o.companion_fraction >= 0.f && o.companion_fraction <= 1.f,
          "companion_fraction must be in [0, 1], got " + std::to_string(o.companion_fraction));
  require(std::isfinite(o.refine_translation) && o.refine_translation >= 0.f && o.refine_translation <= 0.1f,
          "refine_translation must be in [0, 0.1] m, got " + std::to_string(o.refine_translation));
  require(std::isfinite(o.refine_rotation) && o.refine_rotation >= 0.f && o.refine_rotation <= 0.5f,
          "refine_rotation must be in [0, 0.5] rad, got " + std::to_string(o.refine_rotation));
  return o;
}

}  // namespace

void StepMotion::validate(const std::string& owner) const {
  if (!(predicted_fraction >= 0.f && predicted_fraction <= 1.f)) {
    throw std::invalid_argument(owner + ".predicted_fraction must be in [0, 1], got " +
                                std::to_string(predicted_fraction));
  }
  if (!(refine_rounds >= 0 && refine_rounds <= 20)) {
    throw std::invalid_argument(owner + ".refine_rounds must be in [0, 20], got " + std::to_string(refine_rounds));
  }
}

Eigen::Quaternionf rotation_from_rpy(const Eigen::Vector3f& rpy) {
  const Eigen::Quaternionf q = Eigen::AngleAxisf(rpy.z(), Eigen::Vector3f::UnitZ()) *
                               Eigen::AngleAxisf(rpy.y(), Eigen::Vector3f::UnitY()) *
                               Eigen::AngleAxisf(rpy.x(), Eigen::Vector3f::UnitX());
  return q.normalized();
}

Eigen::Vector3f rpy_from_rotation(const Eigen::Quaternionf& rotation) {
  const Eigen::Matrix3f r = rotation.normalized().toRotationMatrix();
  const float pitch = std::asin(std::clamp(-r(2, 0), -1.f, 1.f));
  const float roll = std::atan2(r(2, 1), r(2, 2));
  const float yaw = std::atan2(r(1, 0), r(0, 0));
  return {roll, pitch, yaw};
}

PoseVector pose_difference(const Pose& from, const Pose& to) {
  PoseVector d;
  d.head<3>() = to.translation - from.translation;
  d.tail<3>() = rpy_from_rotation(to.rotation * from.rotation.conjugate());
  return d;
}

Pose apply_increment(const Pose& pose, const PoseVector& increment) {
  Pose out;
  out.translation = pose.translation + increment.head<3>();
  out.rotation = (rotation_from_rpy(increment.tail<3>()) * pose.rotation).normalized();
  return out;
}

void pattern_moves(const Pose& centre, float translation, float rotation, std::span<Pose, kPatternMoves> out) {
  out[0] = centre;
  for (int k = 0; k < 6; ++k) {
    for (int sign = 0; sign < 2; ++sign) {
      PoseVector step = PoseVector::Zero();
      step[k] = (sign == 0 ? 1.f : -1.f) * (k < 3 ? translation : rotation);
      out[static_cast<std::size_t>(1 + 2 * k + sign)] = apply_increment(centre, step);
    }
  }
}

Pose weighted_pose_mean(std::span<const Pose> poses, std::span<const float> weights,
                        const Eigen::Quaternionf& reference) {
  if (poses.size() != weights.size() || poses.empty()) {
    throw std::invalid_argument("weighted_pose_mean: poses and weights must be non-empty and equally long");
  }
  double total = 0.0;
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Matrix4d outer = Eigen::Matrix4d::Zero();
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const double w = weights[i];
    total += w;
    translation += w * poses[i].translation.cast<double>();
    const Eigen::Vector4d q = poses[i].rotation.coeffs().cast<double>();
    outer.noalias() += w * q * q.transpose();
  }
  if (!(total > 0.0)) throw std::invalid_argument("weighted_pose_mean: weights must sum to > 0");
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> solver(outer);
  Eigen::Vector4d mean = solver.eigenvectors().col(3);  // eigenvalues ascend: the largest is last
  if (mean.dot(reference.coeffs().cast<double>()) < 0.0) mean = -mean;
  Pose out;
  out.translation = (translation / total).cast<float>();
  out.rotation.coeffs() = mean.normalized().cast<float>();
  return out;
}

ParticleFilter::ParticleFilter(const ParticleFilterOptions& options)
    : options_(validated(options)), rng_(options.seed) {}

double ParticleFilter::uniform01() {
  return static_cast<double>(rng_() >> 11) * 0x1.0p-53;  // 53 random bits -> [0, 1)
}

// Box-Muller from the filter's own uniforms (std::normal_distribution differs across libraries).
float ParticleFilter::standard_normal() {
  if (has_spare_normal_) {
    has_spare_normal_ = false;
    return spare_normal_;
  }
  const double u1 = 1.0 - uniform01();  // (0, 1]: log stays finite
  const double u2 = uniform01();
  const double radius = std::sqrt(-2.0 * std::log(u1));
  const double angle = 2.0 * std::numbers::pi * u2;
  spare_normal_ = static_cast<float>(radius * std::sin(angle));
  has_spare_normal_ = true;
  return static_cast<float>(radius * std::cos(angle));
}

void ParticleFilter::reset(const Pose& pose) {
  const auto n = static_cast<std::size_t>(options_.num_particles);
  particles_.resize(n);
  drawn_.resize(n);
  weights_.assign(n, 1.f / static_cast<float>(n));
  scores_.assign(n, 0.f);
  cdf_.resize(n);
  for (Pose& p : particles_) {
    PoseVector noise;
    for (int k = 0; k < 6; ++k) noise[k] = options_.init_sigma[k] * standard_normal();
    p = apply_increment(pose, noise);
  }
  estimate_ = pose;
  velocity_.setZero();
  initialised_ = true;
  resample_pending_ = false;
  stepped_last_ = false;
}

void ParticleFilter::resample() {
  const std::size_t n = particles_.size();
  double total = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    total += weights_[i];
    cdf_[i] = total;
  }
  for (double& c : cdf_) c /= total;
  cdf_.back() = 1.0;  // rounding must not leave draws beyond the last bin

  if (options_.resampling == ResamplingScheme::kMultinomial) {
    for (std::size_t i = 0; i < n; ++i) {
      const double u = uniform01();
      // First j with u < c_j, i.e. c_{j-1} <= u < c_j (Algorithm 1).
      const auto j = static_cast<std::size_t>(std::upper_bound(cdf_.begin(), cdf_.end(), u) - cdf_.begin());
      drawn_[i] = particles_[std::min(j, n - 1)];
    }
  } else {
    const double step = 1.0 / static_cast<double>(n);
    const double offset = uniform01() * step;
    std::size_t j = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double u = offset + static_cast<double>(i) * step;
      while (j + 1 < n && cdf_[j] <= u) ++j;
      drawn_[i] = particles_[j];
    }
  }
  particles_.swap(drawn_);
  std::fill(weights_.begin(), weights_.end(), 1.f / static_cast<float>(n));
}

void ParticleFilter::diffuse_and_predict(float predicted_fraction, const PoseVector* companion) {
  const float sqrt_a = std::sqrt(options_.a);
  const float sqrt_b = std::sqrt(options_.b);
  const double fraction = predicted_fraction;
  const double companion_fraction = companion != nullptr ? options_.companion_fraction : 0.0;
  std::size_t unpredicted = 0;  // particles dX left unpredicted so far
  for (std::size_t i = 0; i < particles_.size(); ++i) {
    // Particle i is predicted when floor((i + 1) f) > floor(i f): exactly floor(N f) of them,
    // evenly spread (systematic resampling returns the set ordered by source particle); the same
    // rule over the unpredicted ones picks the companion's.
    const auto i_d = static_cast<double>(i);
    const bool predicted = std::floor((i_d + 1.0) * fraction) > std::floor(i_d * fraction);
    bool by_companion = false;
    if (!predicted) {
      const auto j_d = static_cast<double>(unpredicted++);
      by_companion = std::floor((j_d + 1.0) * companion_fraction) > std::floor(j_d * companion_fraction);
    }
    const PoseVector& motion = by_companion ? *companion : velocity_;
    // N(0, a dX dX^T + b C_init) as the sum of two independent Gaussians (2.14).
    PoseVector noise = sqrt_a * standard_normal() * motion;
    for (int k = 0; k < 6; ++k) noise[k] += sqrt_b * options_.init_sigma[k] * standard_normal();
    Pose p = apply_increment(particles_[i], noise);
    if (predicted || by_companion) p = apply_increment(p, motion);
    particles_[i] = p;
  }
}

const Pose& ParticleFilter::step(const HypothesisData& data, Likelihood& likelihood) {
  return step(data, likelihood, options_.step_motion());
}

const Pose& ParticleFilter::step(const HypothesisData& data, Likelihood& likelihood, const StepMotion& motion) {
  return step(data, likelihood, motion, nullptr);
}

const Pose& ParticleFilter::step(const HypothesisData& data, Likelihood& likelihood, const StepMotion& motion,
                                 const PoseVector* companion) {
  if (!initialised_) throw std::logic_error("ParticleFilter::step called before reset()");
  motion.validate();
  if (companion != nullptr && !companion->allFinite()) {
    throw std::invalid_argument("ParticleFilter::step: the companion's motion must be finite");
  }
  if (resample_pending_) {
    resample();
    diffuse_and_predict(motion.predicted_fraction, companion);
  }
  likelihood.evaluate(particles_, data, scores_);
  likelihood_weights(scores_, options_.lambda, weights_);
  previous_estimate_ = estimate_;
  estimate_ = weighted_pose_mean(particles_, weights_, previous_estimate_.rotation);
  if (motion.refine_rounds > 0) refine(data, likelihood, motion.refine_rounds);
  velocity_ = pose_difference(previous_estimate_, estimate_);
  resample_pending_ = true;
  stepped_last_ = true;
  return estimate_;
}

void ParticleFilter::refine(const HypothesisData& data, Likelihood& likelihood, int rounds) {
  float translation = options_.refine_translation;
  float rotation = options_.refine_rotation;
  candidates_.resize(kPatternMoves);
  candidate_scores_.resize(kPatternMoves);
  for (int round = 0; round < rounds; ++round) {
    pattern_moves(estimate_, translation, rotation, std::span<Pose, kPatternMoves>(candidates_.data(), kPatternMoves));
    likelihood.evaluate(candidates_, data, candidate_scores_);
    // The first of equal scores wins, so the estimate stays unless a move scores higher.
    const auto best = std::max_element(candidate_scores_.begin(), candidate_scores_.end()) - candidate_scores_.begin();
    estimate_ = candidates_[static_cast<std::size_t>(best)];
    translation *= 0.5f;
    rotation *= 0.5f;
  }
}

const Pose& ParticleFilter::hold() {
  if (!initialised_) throw std::logic_error("ParticleFilter::hold called before reset()");
  velocity_.setZero();
  stepped_last_ = false;
  return estimate_;
}

const Pose& ParticleFilter::replace_estimate(const Pose& pose) {
  if (!stepped_last_) throw std::logic_error("ParticleFilter::replace_estimate called without a step() before it");
  if (options_.follow_replaced_estimate > 0.f) {
    const float share = options_.follow_replaced_estimate;
    Pose followed = pose;  // all of the way: exactly there
    if (share < 1.f) {
      followed.translation = estimate_.translation + share * (pose.translation - estimate_.translation);
      followed.rotation = estimate_.rotation.slerp(share, pose.rotation);
    }
    move_particles(followed);
  }
  estimate_ = pose;
  velocity_ = pose_difference(previous_estimate_, estimate_);
  return estimate_;
}

void ParticleFilter::move_particles(const Pose& pose) {
  const Eigen::Isometry3f move = pose.isometry() * estimate_.isometry().inverse();
  for (Pose& particle : particles_) particle = Pose::from_isometry(move * particle.isometry());
}

const Pose& ParticleFilter::move_to(const Pose& pose) {
  if (!initialised_) throw std::logic_error("ParticleFilter::move_to called before reset()");
  move_particles(pose);
  velocity_ = pose_difference(estimate_, pose);
  estimate_ = pose;
  stepped_last_ = false;
  return estimate_;
}

float ParticleFilter::effective_sample_size() const {
  double sum_sq = 0.0;
  for (const float w : weights_) sum_sq += static_cast<double>(w) * w;
  return sum_sq > 0.0 ? static_cast<float>(1.0 / sum_sq) : 0.f;
}

}  // namespace mfot
