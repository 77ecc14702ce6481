// SIR particle filter over SE(3) (thesis 2.2.2, Algorithm 1, 2.12-2.15, 3.21) tracking a synthetic
// coloured object with the CPU JCSD likelihood.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "mfot/hypothesis.hpp"
#include "mfot/jcsd_likelihood.hpp"
#include "mfot/particle_filter.hpp"
#include "synthetic_object.hpp"

namespace mfot {
namespace {

using test::degrees;
using test::radians;

TEST(PoseIncrement, DifferenceAndApplicationAreInverse) {
  const Pose a = test::make_pose(Eigen::Vector3f(0.1f, 0.2f, 0.9f), Eigen::Vector3f(1.f, -2.f, 0.5f), 2.5f);
  const Pose b = test::make_pose(Eigen::Vector3f(0.12f, 0.18f, 0.95f), Eigen::Vector3f(-1.f, 0.3f, 2.f), 0.7f);
  const Pose back = apply_increment(a, pose_difference(a, b));
  EXPECT_LT(test::translation_error(back, b), 1e-6f);
  EXPECT_LT(test::rotation_error(back, b), 1e-5f);
  // A pure yaw increment of 10 degrees is (0, 0, 0, 0, 0, 0.1745) whatever the start rotation.
  PoseVector yaw = PoseVector::Zero();
  yaw[5] = radians(10.f);
  const PoseVector d = pose_difference(a, apply_increment(a, yaw));
  EXPECT_LT((d - yaw).norm(), 1e-5f);
}

TEST(PoseIncrement, RollPitchYawRoundTrip) {
  const Eigen::Vector3f rpy(0.3f, -0.7f, 2.9f);
  EXPECT_LT((rpy_from_rotation(rotation_from_rpy(rpy)) - rpy).norm(), 1e-5f);
  // Rz(yaw) Ry(pitch) Rx(roll): roll alone rotates y into z.
  const Eigen::Vector3f y_rolled =
      rotation_from_rpy(Eigen::Vector3f(std::numbers::pi_v<float> / 2, 0.f, 0.f)) * Eigen::Vector3f::UnitY();
  EXPECT_LT((y_rolled - Eigen::Vector3f::UnitZ()).norm(), 1e-6f);
}

TEST(WeightedPoseMean, AveragesRotationsIndependentlyOfQuaternionSign) {
  // +-20 degrees about z with equal weights average to the identity, even with one quaternion
  // stored with the opposite sign (naive coefficient averaging would give nonsense).
  Pose plus = test::make_pose(Eigen::Vector3f(1.f, 0.f, 0.f), Eigen::Vector3f::UnitZ(), radians(20.f));
  Pose minus = test::make_pose(Eigen::Vector3f(3.f, 0.f, 0.f), Eigen::Vector3f::UnitZ(), radians(-20.f));
  minus.rotation.coeffs() = -minus.rotation.coeffs();
  const std::vector<Pose> poses{plus, minus};
  const std::vector<float> equal{1.f, 1.f};
  const Pose mean = weighted_pose_mean(poses, equal);
  EXPECT_LT(test::rotation_error(mean, Pose{}), 1e-5f);
  EXPECT_GT(mean.rotation.w(), 0.f);  // sign follows the reference (identity)
  EXPECT_NEAR(mean.translation.x(), 2.f, 1e-6f);
  // Weights 3:1 on 0 and 40 degrees about x: the quaternion mean lies at about 10 degrees.
  const std::vector<Pose> skewed{test::make_pose(Eigen::Vector3f::Zero(), Eigen::Vector3f::UnitX(), 0.f),
                                 test::make_pose(Eigen::Vector3f::Zero(), Eigen::Vector3f::UnitX(), radians(40.f))};
  const std::vector<float> three_to_one{3.f, 1.f};
  const float angle = degrees(test::rotation_error(weighted_pose_mean(skewed, three_to_one), Pose{}));
  EXPECT_GT(angle, 8.f);
  EXPECT_LT(angle, 12.f);
}

// 2 cm and 10 degrees per frame is fast (the thesis tracks at 21 FPS): more particles than the
// thesis's 200 and more of them predicted keep the error under 3 mm and 2 degrees.
ParticleFilterOptions tracking_options(std::uint64_t seed) {
  ParticleFilterOptions o;
  o.num_particles = 1000;
  o.predicted_fraction = 0.8f;
  o.seed = seed;
  return o;
}

// The test object (10 x 15 x 8 cm, six colours) starting from rest, speeding up over the first
// kRampFrames frames, then moving 2 cm and turning 10 degrees per frame for kFullSpeedFrames
// frames, with a slowly changing direction of motion and axis of rotation. Observed points are
// sampled between the model's points (phase 0.5) and exactly on the surface (noise-free).
constexpr int kRampFrames = 10;
constexpr int kFullSpeedFrames = 100;

struct MovingObject {
  ObjectModel model = test::make_model(test::make_test_object(0.f));
  ColoredCloud object = test::make_test_object(0.5f);

  Pose pose_at(int frame) const {
    Pose p = test::make_pose(Eigen::Vector3f(-0.5f, 0.f, 1.2f), Eigen::Vector3f(0.2f, 1.f, 0.1f), 0.3f);
    for (int k = 1; k <= frame; ++k) {
      const float speed = std::min(1.f, static_cast<float>(k) / static_cast<float>(kRampFrames));
      const float phase = 0.05f * static_cast<float>(k);
      PoseVector d;
      d.head<3>() = speed * 0.02f * Eigen::Vector3f(std::cos(phase), 0.3f * std::sin(phase), 0.2f).normalized();
      const Eigen::Vector3f axis = Eigen::Vector3f(std::sin(phase), 1.f, 0.5f * std::cos(phase)).normalized();
      const Eigen::Quaternionf turn(Eigen::AngleAxisf(speed * radians(10.f), axis));
      p.translation += d.head<3>();
      p.rotation = (turn * p.rotation).normalized();
    }
    return p;
  }
};

struct TrackResult {
  std::vector<Pose> estimates;
  // Over the full-speed frames: translation in m, rotation in rad.
  float max_translation_error = 0.f;
  float max_rotation_error = 0.f;
  float mean_translation_error = 0.f;
  float mean_rotation_error = 0.f;
  // Over the ramp, while the filter picks up the velocity through dX (2.13, 2.15).
  float ramp_max_translation_error = 0.f;
  float ramp_max_rotation_error = 0.f;
};

// motion: each step's StepMotion in place of the options' (nullptr: step with the options').
// companion: each step is given the object's true last step as a companion's motion (a hand gripping
// it whose estimate follows the motion exactly).
TrackResult track(const MovingObject& scene, const ParticleFilterOptions& options, const StepMotion* motion = nullptr,
                  bool companion = false) {
  JcsdLikelihood likelihood;
  likelihood.set_model(scene.model);
  ParticleFilter filter(options);
  filter.reset(scene.pose_at(0));
  HypothesisData data;
  TrackResult r;
  int counted = 0;
  for (int frame = 1; frame <= kRampFrames + kFullSpeedFrames; ++frame) {
    const Pose truth = scene.pose_at(frame);
    ColoredCloud frame_points = test::transformed(scene.object, truth);
    frame_points.push_back(truth.translation + Eigen::Vector3f(0.4f, 0.f, 0.f), Rgb8{255, 0, 0});  // clutter
    const std::vector<SmrFeature> features = compute_smr(frame_points.colors);
    select_hypothesis_data(frame_points, features, scene.model, filter.estimate(), HypothesisOptions{0.06f}, data);
    const PoseVector last_step = pose_difference(scene.pose_at(std::max(0, frame - 2)), scene.pose_at(frame - 1));
    const StepMotion step_motion = motion != nullptr ? *motion : options.step_motion();
    const Pose estimate = companion           ? filter.step(data, likelihood, step_motion, &last_step)
                          : motion != nullptr ? filter.step(data, likelihood, *motion)
                                              : filter.step(data, likelihood);
    r.estimates.push_back(estimate);
    const float te = test::translation_error(estimate, truth);
    const float re = test::rotation_error(estimate, truth);
    if (frame <= kRampFrames) {
      r.ramp_max_translation_error = std::max(r.ramp_max_translation_error, te);
      r.ramp_max_rotation_error = std::max(r.ramp_max_rotation_error, re);
      continue;
    }
    r.max_translation_error = std::max(r.max_translation_error, te);
    r.max_rotation_error = std::max(r.max_rotation_error, re);
    r.mean_translation_error += te;
    r.mean_rotation_error += re;
    ++counted;
  }
  r.mean_translation_error /= static_cast<float>(counted);
  r.mean_rotation_error /= static_cast<float>(counted);
  return r;
}

TEST(ParticleFilter, TracksAFastMovingObject) {
  const MovingObject scene;
  const ParticleFilterOptions options = tracking_options(7);
  const TrackResult r = track(scene, options);
  std::printf(
      "tracking, %d particles, JCSD CPU, noise-free points:\n"
      "  %d frames at 2 cm + 10 deg/frame: translation mean %.2f mm max %.2f mm, rotation mean %.2f deg max %.2f deg\n"
      "  %d ramp frames from rest: max %.2f mm, %.2f deg\n",
      options.num_particles, kFullSpeedFrames, 1e3f * r.mean_translation_error, 1e3f * r.max_translation_error,
      degrees(r.mean_rotation_error), degrees(r.max_rotation_error), kRampFrames, 1e3f * r.ramp_max_translation_error,
      degrees(r.ramp_max_rotation_error));
  EXPECT_LT(r.max_translation_error, 0.003f);
  EXPECT_LT(degrees(r.max_rotation_error), 2.f);
  // While it picks up the velocity the filter lags a little but must not lose the object.
  EXPECT_LT(r.ramp_max_translation_error, 0.006f);
  EXPECT_LT(degrees(r.ramp_max_rotation_error), 6.f);
}

TEST(ParticleFilter, RefinementFollowsAThinParticleSetCloser) {
  const MovingObject scene;
  ParticleFilterOptions options = tracking_options(7);
  options.num_particles = 30;  // thin over 6 DoF: the weighted mean lags
  const TrackResult mean_only = track(scene, options);
  const StepMotion three_rounds{options.predicted_fraction, 3};
  const TrackResult refined = track(scene, options, &three_rounds);
  std::printf(
      "30 particles: rotation mean %.2f -> %.2f deg, translation mean %.2f -> %.2f mm with 3 refinement rounds\n",
      degrees(mean_only.mean_rotation_error), degrees(refined.mean_rotation_error),
      1e3f * mean_only.mean_translation_error, 1e3f * refined.mean_translation_error);
  EXPECT_LT(refined.mean_rotation_error, 0.8f * mean_only.mean_rotation_error);
  EXPECT_LT(refined.mean_translation_error, mean_only.mean_translation_error);
  EXPECT_LT(degrees(refined.max_rotation_error), 15.f);  // never lost (the mean-only filter is, at 54 deg)
}

TEST(ParticleFilter, AStepsMotionTakesThePlaceOfTheOptions) {
  const MovingObject scene;
  ParticleFilterOptions thesis = tracking_options(7);
  thesis.num_particles = 30;
  thesis.predicted_fraction = 0.5f;
  ParticleFilterOptions harder = thesis;
  harder.predicted_fraction = 0.9f;
  const StepMotion follow = harder.step_motion();
  EXPECT_EQ(follow.refine_rounds, 0);  // the options' own step: the weighted mean only
  const TrackResult by_options = track(scene, harder);
  const TrackResult by_step = track(scene, thesis, &follow);
  ASSERT_EQ(by_step.estimates.size(), by_options.estimates.size());
  for (std::size_t k = 0; k < by_step.estimates.size(); ++k) {
    ASSERT_EQ(by_step.estimates[k].translation, by_options.estimates[k].translation) << "frame " << k + 1;
    ASSERT_EQ(by_step.estimates[k].rotation.coeffs(), by_options.estimates[k].rotation.coeffs()) << "frame " << k + 1;
  }
  // A step that follows harder (more particles predicted, refinement rounds) follows the thin set closer.
  const StepMotion refined{0.9f, 3};
  const TrackResult by_refined_step = track(scene, thesis, &refined);
  const TrackResult plain = track(scene, thesis);
  EXPECT_LT(by_refined_step.mean_rotation_error, 0.8f * plain.mean_rotation_error);

  JcsdLikelihood likelihood;
  likelihood.set_model(scene.model);
  ParticleFilter filter(thesis);
  filter.reset(scene.pose_at(0));
  EXPECT_THROW(filter.step(HypothesisData{}, likelihood, StepMotion{1.5f, 0}), std::invalid_argument);
  EXPECT_THROW(filter.step(HypothesisData{}, likelihood, StepMotion{0.5f, 21}), std::invalid_argument);
}

TEST(ParticleFilter, ACompanionsMotionMovesAShareOfTheUnpredictedParticles) {
  const MovingObject scene;
  ParticleFilterOptions thesis = tracking_options(7);
  thesis.num_particles = 30;  // thin: the thesis's own dX lags, most of all while the motion picks up
  thesis.predicted_fraction = 0.5f;
  ParticleFilterOptions with_companion = thesis;
  with_companion.companion_fraction = 0.5f;
  const TrackResult plain = track(scene, thesis);
  const TrackResult followed = track(scene, with_companion, nullptr, true);
  std::printf("30 particles: rotation mean %.2f -> %.2f deg (ramp max %.2f -> %.2f) with a companion's motion\n",
              degrees(plain.mean_rotation_error), degrees(followed.mean_rotation_error),
              degrees(plain.ramp_max_rotation_error), degrees(followed.ramp_max_rotation_error));
  EXPECT_LT(followed.mean_rotation_error, 0.8f * plain.mean_rotation_error);
  EXPECT_LT(followed.mean_translation_error, plain.mean_translation_error);
  EXPECT_LT(degrees(followed.max_rotation_error), 15.f);  // kept (the thesis's step loses it)

  // Without a companion's motion, or with companion_fraction 0, the step is the thesis's draw for draw.
  const TrackResult unused = track(scene, with_companion);
  const TrackResult none_moved = track(scene, thesis, nullptr, true);
  for (std::size_t k = 0; k < plain.estimates.size(); ++k) {
    ASSERT_EQ(unused.estimates[k].translation, plain.estimates[k].translation) << "frame " << k + 1;
    ASSERT_EQ(none_moved.estimates[k].rotation.coeffs(), plain.estimates[k].rotation.coeffs()) << "frame " << k + 1;
  }

  JcsdLikelihood likelihood;
  likelihood.set_model(scene.model);
  ParticleFilter filter(with_companion);
  filter.reset(scene.pose_at(0));
  PoseVector broken = PoseVector::Zero();
  broken[4] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(filter.step(HypothesisData{}, likelihood, StepMotion{}, &broken), std::invalid_argument);
  ParticleFilterOptions invalid = thesis;
  invalid.companion_fraction = 1.5f;
  EXPECT_THROW(ParticleFilter{invalid}, std::invalid_argument);
}

TEST(ParticleFilter, SameSeedIsBitIdenticalAndOtherSeedsDiffer) {
  const MovingObject scene;
  ParticleFilterOptions short_run = tracking_options(3);
  const auto run = [&](std::uint64_t seed) {
    ParticleFilterOptions o = short_run;
    o.seed = seed;
    JcsdLikelihood likelihood;
    likelihood.set_model(scene.model);
    ParticleFilter filter(o);
    filter.reset(scene.pose_at(0));
    std::vector<float> trace;
    for (int frame = 1; frame <= 10; ++frame) {
      const Pose e =
          filter.step(test::make_hypothesis(test::transformed(scene.object, scene.pose_at(frame))), likelihood);
      trace.insert(trace.end(), {e.translation.x(), e.translation.y(), e.translation.z(), e.rotation.w(),
                                 e.rotation.x(), e.rotation.y(), e.rotation.z()});
    }
    for (const Pose& p : filter.particles()) trace.push_back(p.translation.x());
    return trace;
  };
  EXPECT_EQ(run(3), run(3));
  EXPECT_NE(run(3), run(4));
}

TEST(ParticleFilter, ExposesWeightsAndVelocity) {
  const MovingObject scene;
  JcsdLikelihood likelihood;
  likelihood.set_model(scene.model);
  ParticleFilter filter(tracking_options(5));
  EXPECT_FALSE(filter.initialised());
  EXPECT_THROW(filter.step(HypothesisData{}, likelihood), std::logic_error);
  filter.reset(scene.pose_at(0));
  ASSERT_EQ(filter.particles().size(), 1000u);
  EXPECT_NEAR(filter.effective_sample_size(), 1000.f, 1e-2f);  // uniform weights after reset
  for (int frame = 1; frame <= 8; ++frame) {
    filter.step(test::make_hypothesis(test::transformed(scene.object, scene.pose_at(frame))), likelihood);
  }
  float sum = 0.f;
  for (const float w : filter.weights()) sum += w;
  EXPECT_NEAR(sum, 1.f, 1e-4f);
  EXPECT_GE(filter.effective_sample_size(), 1.f);
  EXPECT_LE(filter.effective_sample_size(), 1000.f + 1e-2f);
  // The last dX (2.13) follows the true motion of frame 8 (still on the ramp: 1.6 cm, 8 degrees).
  const PoseVector truth = pose_difference(scene.pose_at(7), scene.pose_at(8));
  EXPECT_NEAR(filter.velocity().head<3>().norm(), truth.head<3>().norm(), 0.003f);
  const auto angle = [](const PoseVector& d) {
    return degrees(rotation_from_rpy(d.tail<3>()).angularDistance(Eigen::Quaternionf::Identity()));
  };
  EXPECT_NEAR(angle(truth), 8.f, 0.01f);
  EXPECT_NEAR(angle(filter.velocity()), angle(truth), 2.f);
  // With no data every particle scores 0: uniform weights, estimate stays put.
  const Pose before = filter.estimate();
  filter.step(HypothesisData{}, likelihood);
  EXPECT_NEAR(filter.effective_sample_size(), 1000.f, 1e-2f);
  EXPECT_LT(test::translation_error(filter.estimate(), before), 0.05f);
}

TEST(ParticleFilter, HoldKeepsTheEstimateAndForgetsTheMotion) {
  const MovingObject scene;
  JcsdLikelihood likelihood;
  likelihood.set_model(scene.model);
  ParticleFilter filter(tracking_options(11));
  EXPECT_THROW(filter.hold(), std::logic_error);
  filter.reset(scene.pose_at(0));
  for (int frame = 1; frame <= 6; ++frame) {
    filter.step(test::make_hypothesis(test::transformed(scene.object, scene.pose_at(frame))), likelihood);
  }
  ASSERT_GT(filter.velocity().norm(), 0.f);
  const Pose before = filter.estimate();
  const std::vector<Pose> particles(filter.particles().begin(), filter.particles().end());
  const Pose held = filter.hold();
  EXPECT_TRUE(held.translation.isApprox(before.translation) && held.rotation.isApprox(before.rotation));
  EXPECT_EQ(filter.velocity(), PoseVector::Zero());
  ASSERT_EQ(filter.particles().size(), particles.size());
  for (std::size_t i = 0; i < particles.size(); ++i) {
    EXPECT_EQ(filter.particles()[i].translation, particles[i].translation);
  }
  // The object reappears where it was hidden: the filter takes it up again from the held pose.
  for (int frame = 0; frame < 5; ++frame) {
    filter.step(test::make_hypothesis(test::transformed(scene.object, scene.pose_at(6))), likelihood);
  }
  EXPECT_LT(test::translation_error(filter.estimate(), scene.pose_at(6)), 0.003f);
}

TEST(ParticleFilter, AReplacedEstimateGivesTheNextPrediction) {
  const MovingObject scene;
  JcsdLikelihood likelihood;
  likelihood.set_model(scene.model);
  ParticleFilter filter(tracking_options(13));
  filter.reset(scene.pose_at(0));
  EXPECT_THROW(filter.replace_estimate(scene.pose_at(0)), std::logic_error);  // no step yet
  Pose before;
  for (int frame = 1; frame <= 4; ++frame) {
    before = filter.estimate();
    filter.step(test::make_hypothesis(test::transformed(scene.object, scene.pose_at(frame))), likelihood);
  }
  // The truth in place of the weighted mean: dX is the motion from the estimate before the step to it.
  const Pose& replaced = filter.replace_estimate(scene.pose_at(4));
  EXPECT_EQ(replaced.translation, scene.pose_at(4).translation);
  EXPECT_EQ(filter.estimate().rotation.coeffs(), scene.pose_at(4).rotation.coeffs());
  const PoseVector expected = pose_difference(before, scene.pose_at(4));
  EXPECT_TRUE(filter.velocity().isApprox(expected, 1e-5f))
      << filter.velocity().transpose() << " vs " << expected.transpose();
  filter.hold();
  EXPECT_THROW(filter.replace_estimate(scene.pose_at(4)), std::logic_error);  // a held frame has no step to refine
}

// With follow_replaced_estimate, the refined pose takes the particle set that share of the way: every particle
// moved by the rigid motion from the step's estimate to the pose that share of the way to the refined one (all of
// it at 1), weights and dX as without it. At 0, the set stays where the step left it.
TEST(ParticleFilter, AReplacedEstimateMovesTheParticlesItsShareOfTheWay) {
  const MovingObject scene;
  JcsdLikelihood likelihood;
  likelihood.set_model(scene.model);
  const HypothesisData data = test::make_hypothesis(test::transformed(scene.object, scene.pose_at(1)));
  const PoseVector correction = (PoseVector() << 0.004f, -0.002f, 0.003f, 0.f, 0.05f, -0.08f).finished();
  for (const float share : {0.f, 0.5f, 1.f}) {
    ParticleFilterOptions options = tracking_options(21);
    options.follow_replaced_estimate = share;
    ParticleFilter filter(options);
    filter.reset(scene.pose_at(0));
    filter.step(data, likelihood);
    const Pose stepped = filter.estimate();
    const std::vector<Pose> before(filter.particles().begin(), filter.particles().end());
    const std::vector<float> weights(filter.weights().begin(), filter.weights().end());
    const Pose refined = apply_increment(stepped, correction);
    filter.replace_estimate(refined);
    Pose followed;
    followed.translation = stepped.translation + share * (refined.translation - stepped.translation);
    followed.rotation = stepped.rotation.slerp(share, refined.rotation);
    const Eigen::Isometry3f motion = followed.isometry() * stepped.isometry().inverse();
    for (std::size_t i = 0; i < before.size(); ++i) {
      const Pose expected = Pose::from_isometry(motion * before[i].isometry());
      EXPECT_LT(test::translation_error(filter.particles()[i], expected), 1e-5f)
          << "share " << share << ", particle " << i;
      EXPECT_LT(test::rotation_error(filter.particles()[i], expected), 1e-4f)
          << "share " << share << ", particle " << i;
      EXPECT_EQ(filter.weights()[i], weights[i]);
    }
    if (share == 0.f) {
      EXPECT_EQ(filter.particles()[0].translation, before[0].translation);  // untouched
    }
    EXPECT_EQ(filter.estimate().translation, refined.translation);
    EXPECT_TRUE(filter.velocity().isApprox(pose_difference(scene.pose_at(0), refined), 1e-5f));  // from the reset pose
  }
  ParticleFilterOptions invalid = tracking_options(21);
  invalid.follow_replaced_estimate = 1.5f;
  EXPECT_THROW(ParticleFilter{invalid}, std::invalid_argument);
}

// move_to (a hidden object carried by another): every particle moved by the same rigid motion that
// takes the estimate to the new pose, weights kept, dX = that motion.
TEST(ParticleFilter, MovingToAPoseCarriesTheWholeParticleSetRigidly) {
  ParticleFilter filter(tracking_options(5));
  EXPECT_THROW(filter.move_to(Pose{}), std::logic_error);  // before reset
  const Pose start =
      test::make_pose(Eigen::Vector3f(0.1f, 0.f, 1.f), Eigen::Vector3f(0.f, 1.f, 1.f).normalized(), 0.3f);
  filter.reset(start);
  const std::vector<Pose> before(filter.particles().begin(), filter.particles().end());
  const std::vector<float> weights(filter.weights().begin(), filter.weights().end());
  const Pose target = test::make_pose(Eigen::Vector3f(0.12f, 0.03f, 0.95f), Eigen::Vector3f(1.f, 0.f, 0.f), 0.9f);
  const Pose& moved = filter.move_to(target);
  EXPECT_EQ(moved.translation, target.translation);
  EXPECT_EQ(filter.estimate().rotation.coeffs(), target.rotation.coeffs());
  const Eigen::Isometry3f motion = target.isometry() * start.isometry().inverse();
  for (std::size_t i = 0; i < before.size(); ++i) {
    const Pose expected = Pose::from_isometry(motion * before[i].isometry());
    EXPECT_LT(test::translation_error(filter.particles()[i], expected), 1e-5f) << "particle " << i;
    EXPECT_LT(test::rotation_error(filter.particles()[i], expected), 1e-4f) << "particle " << i;
    EXPECT_EQ(filter.weights()[i], weights[i]);
  }
  EXPECT_TRUE(filter.velocity().isApprox(pose_difference(start, target), 1e-5f));
  EXPECT_THROW(filter.replace_estimate(target), std::logic_error);  // no step to refine
}

TEST(ParticleFilter, ResamplingSchemesBothTrack) {
  const MovingObject scene;
  ParticleFilterOptions o = tracking_options(9);
  o.resampling = ResamplingScheme::kMultinomial;
  const TrackResult r = track(scene, o);
  EXPECT_LT(r.mean_translation_error, 0.003f);
  EXPECT_LT(degrees(r.mean_rotation_error), 2.f);
}

TEST(ParticleFilter, InvalidOptionsThrow) {
  const auto bad = [](auto mutate) {
    ParticleFilterOptions o;
    mutate(o);
    EXPECT_THROW(ParticleFilter{o}, std::invalid_argument);
  };
  bad([](ParticleFilterOptions& o) { o.num_particles = 0; });
  bad([](ParticleFilterOptions& o) { o.init_sigma[4] = -0.1f; });
  bad([](ParticleFilterOptions& o) { o.a = -1.f; });
  bad([](ParticleFilterOptions& o) { o.b = std::nanf(""); });
  bad([](ParticleFilterOptions& o) { o.lambda = 0.f; });
  bad([](ParticleFilterOptions& o) { o.predicted_fraction = 1.5f; });
  EXPECT_THROW((StepMotion{0.5f, -1}.validate()), std::invalid_argument);
}

}  // namespace
}  // namespace mfot
