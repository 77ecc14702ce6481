// Hypothesis evaluation: weights of 3.21, the CPU JCSD likelihood (3.18-3.20), the [CC13]
// point-to-point baseline (2.18-2.21) and hypothesis-data selection (3.3).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

#include "mfot/hypothesis.hpp"
#include "mfot/jcsd_likelihood.hpp"
#include "mfot/likelihood.hpp"
#include "mfot/particle_filter.hpp"
#include "mfot/point_to_point_likelihood.hpp"
#include "synthetic_object.hpp"

namespace mfot {
namespace {

using test::radians;

const Pose kTruePose = test::make_pose(Eigen::Vector3f(0.1f, -0.05f, 0.8f), Eigen::Vector3f(1.f, 2.f, 3.f), 0.5f);

// The true pose first, then single-axis perturbations of 3 to 20 mm and 3 to 20 degrees, then
// random combinations of both.
std::vector<Pose> candidate_poses() {
  std::vector<Pose> poses{kTruePose};
  for (const float sign : {-1.f, 1.f}) {
    for (int axis = 0; axis < 3; ++axis) {
      for (const float mm : {3.f, 6.f, 10.f, 20.f}) {
        PoseVector d = PoseVector::Zero();
        d[axis] = sign * mm * 1e-3f;
        poses.push_back(apply_increment(kTruePose, d));
      }
      for (const float deg : {3.f, 6.f, 10.f, 20.f}) {
        PoseVector d = PoseVector::Zero();
        d[3 + axis] = sign * radians(deg);
        poses.push_back(apply_increment(kTruePose, d));
      }
    }
  }
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<float> unit(-1.f, 1.f);  // test inputs only; results need no bit-stability
  for (int k = 0; k < 60; ++k) {
    PoseVector d;
    for (int i = 0; i < 3; ++i) d[i] = 0.01f * unit(rng);
    for (int i = 3; i < 6; ++i) d[i] = radians(10.f) * unit(rng);
    poses.push_back(apply_increment(kTruePose, d));
  }
  return poses;
}

// Index of the best score, and how many candidates score at least as well as the true pose (0).
std::size_t rank_of_true_pose(const std::vector<float>& scores) {
  return static_cast<std::size_t>(
      std::count_if(scores.begin() + 1, scores.end(), [&](float s) { return s >= scores[0]; }));
}

// The model, and the object observed at kTruePose. observation_phase 0 samples the surface at
// the model's points; 0.5 shifts the sampling so no observed point coincides with a model point.
struct Scene {
  explicit Scene(float observation_phase = 0.5f)
      : observed(test::transformed(test::make_test_object(observation_phase), kTruePose)) {}
  ObjectModel model = test::make_model(test::make_test_object(0.f));
  ColoredCloud observed;
};

TEST(LikelihoodWeights, FollowEquation321) {
  // s = {0, 5, 10}, lambda = 2: exponents -2 (1 - 0), -2 (1 - 0.5) = -1, 0.
  // exp: 0.135335, 0.367879, 1 -> total 1.503214 -> 0.090031, 0.244728, 0.665241.
  const std::vector<float> scores{0.f, 5.f, 10.f};
  std::vector<float> w(3);
  likelihood_weights(scores, 2.f, w);
  EXPECT_NEAR(w[0], 0.090031f, 1e-5f);
  EXPECT_NEAR(w[1], 0.244728f, 1e-5f);
  EXPECT_NEAR(w[2], 0.665241f, 1e-5f);
}

TEST(LikelihoodWeights, EqualScoresGiveUniformWeightsAndBadInputThrows) {
  const std::vector<float> scores(4, 3.f);
  std::vector<float> w(4);
  likelihood_weights(scores, 5.f, w);
  for (const float x : w) EXPECT_EQ(x, 0.25f);
  EXPECT_THROW(likelihood_weights(scores, 0.f, w), std::invalid_argument);
  EXPECT_THROW(likelihood_weights(scores, std::nanf(""), w), std::invalid_argument);
  std::vector<float> short_w(3);
  EXPECT_THROW(likelihood_weights(scores, 1.f, short_w), std::invalid_argument);
}

TEST(JcsdLikelihood, MatchesTheReferenceEvaluation) {
  const Scene scene;
  JcsdLikelihood likelihood;
  likelihood.set_model(scene.model);
  const HypothesisData data = test::make_hypothesis(scene.observed);
  const std::vector<Pose> poses = candidate_poses();
  std::vector<float> scores(poses.size());
  likelihood.evaluate(poses, data, scores);
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const Eigen::Isometry3f to_object = poses[i].isometry().inverse();
    double reference = 0.0;
    for (std::size_t j = 0; j < data.points.size(); ++j) {
      reference += jcsd_point_score(likelihood.grid(), to_object * data.points[j], data.features[j]);
    }
    EXPECT_NEAR(scores[i], reference, 1e-4 * reference + 1e-6) << "pose " << i;
  }
  EXPECT_GT(scores[0], 0.f);
}

TEST(JcsdLikelihood, ResultsDoNotDependOnTheThreadCount) {
  const Scene scene;
  const HypothesisData data = test::make_hypothesis(scene.observed);
  const std::vector<Pose> poses = candidate_poses();
  std::vector<float> single(poses.size()), multi(poses.size());
  JcsdLikelihood one(JcsdLikelihoodOptions{{}, 1});
  JcsdLikelihood three(JcsdLikelihoodOptions{{}, 3});
  one.set_model(scene.model);
  three.set_model(scene.model);
  one.evaluate(poses, data, single);
  for (int repeat = 0; repeat < 3; ++repeat) {
    three.evaluate(poses, data, multi);
    EXPECT_EQ(single, multi);
  }
}

TEST(JcsdLikelihood, PointsOutsideTheGridScoreZero) {
  const Scene scene;
  JcsdLikelihood likelihood;
  likelihood.set_model(scene.model);
  HypothesisData far = test::make_hypothesis(test::transformed(test::make_test_object(), kTruePose));
  const Pose away = test::make_pose(Eigen::Vector3f(5.f, 0.f, 0.f), Eigen::Vector3f::UnitZ(), 0.f);
  const Pose at_origin;  // the data sits 0.8 m from the identity pose's object frame
  std::vector<float> scores(2);
  const std::vector<Pose> poses{away, at_origin};
  likelihood.evaluate(poses, far, scores);
  EXPECT_EQ(scores[0], 0.f);
  EXPECT_EQ(scores[1], 0.f);
  // No model or no data: all zero.
  JcsdLikelihood empty;
  empty.evaluate(poses, far, scores);
  EXPECT_EQ(scores[0], 0.f);
  likelihood.evaluate(poses, HypothesisData{}, scores);
  EXPECT_EQ(scores[1], 0.f);
}

TEST(JcsdLikelihood, MatchesTheReferenceAtTheGridFacesAndForNonFinitePoints) {
  // Every bin of J is a positive linear function of the corner, so interpolation is exact. The cell
  // size and origin are powers of two: the evaluator and the reference map points to the same grid
  // units, and points in the last cell of each axis (which read the grid's last corners), on the
  // far faces (outside), below the origin, huge or not finite are placed exactly.
  JcsdGrid grid;
  grid.origin = Eigen::Vector3f(0.25f, -0.5f, 1.f);
  grid.cell_size = 0.5f;
  grid.dims = {5, 4, 6};
  grid.values.resize(grid.num_corners() * kSmrBins);
  for (int z = 0; z < grid.dims[2]; ++z)
    for (int y = 0; y < grid.dims[1]; ++y)
      for (int x = 0; x < grid.dims[0]; ++x)
        for (int c = 0; c < kSmrBins; ++c)
          grid.values[((static_cast<std::size_t>(z) * grid.dims[1] + y) * grid.dims[0] + x) * kSmrBins + c] =
              7.f + static_cast<float>(c) + 2.f * x + 3.f * y - 1.f * z;
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<Eigen::Vector3f> units{
      {1.25f, 1.5f, 2.75f}, {3.75f, 2.5f, 4.5f}, {3.999f, 0.5f, 0.5f}, {0.f, 0.f, 0.f},     // inside
      {4.f, 1.f, 1.f},      {1.f, 3.f, 1.f},     {1.f, 1.f, 5.5f},     {-0.25f, 1.f, 1.f},  // outside
      {1e30f, 1.f, 1.f},    {inf, 1.f, 1.f},     {1.f, -inf, 1.f},     {1.f, 1.f, nan}};
  // Hues in every bin, including 345 degrees (bin 6 of 6, whose upper neighbour is bin 1), dark and light.
  const std::vector<Rgb8> colours{{255, 0, 0},   {255, 0, 64},    {0, 255, 0},    {0, 0, 255},
                                  {40, 40, 40},  {255, 255, 255}, {200, 150, 50}, {20, 60, 200},
                                  {0, 200, 200}, {180, 0, 255},   {90, 30, 10},   {128, 128, 128}};
  HypothesisData all;
  for (std::size_t k = 0; k < units.size(); ++k) {
    all.points.push_back(grid.origin + grid.cell_size * units[k]);
    all.colors.push_back(colours[k]);
  }
  all.features = compute_smr(all.colors);

  JcsdLikelihood likelihood;
  likelihood.set_grid(grid);
  const std::vector<Pose> identity(1);
  std::vector<float> score(1);
  double total = 0.0;
  for (std::size_t k = 0; k < units.size(); ++k) {
    const float reference = jcsd_point_score(grid, all.points[k], all.features[k]);
    EXPECT_EQ(reference > 0.f, k < 4) << "point " << k;
    HypothesisData one;
    one.points = {all.points[k]};
    one.colors = {all.colors[k]};
    one.features = {all.features[k]};
    likelihood.evaluate(identity, one, score);
    EXPECT_NEAR(score[0], reference, 1e-5f * reference) << "point " << k;
    total += reference;
  }
  likelihood.evaluate(identity, all, score);
  EXPECT_NEAR(score[0], total, 1e-5 * total);
}

TEST(JcsdLikelihood, InvalidInputThrows) {
  EXPECT_THROW(JcsdLikelihood(JcsdLikelihoodOptions{{}, 0}), std::invalid_argument);
  EXPECT_THROW(JcsdLikelihood(JcsdLikelihoodOptions{{0.f, 1}, 1}), std::invalid_argument);
  JcsdLikelihood likelihood;
  std::vector<Pose> poses(2);
  std::vector<float> scores(1);
  EXPECT_THROW(likelihood.evaluate(poses, HypothesisData{}, scores), std::invalid_argument);
}

TEST(Ranking, TruePoseScoresHighestForBothBackends) {
  // Noise-free, unoccluded, sampled like the model.
  const Scene scene(0.f);
  const HypothesisData data = test::make_hypothesis(scene.observed);
  const std::vector<Pose> poses = candidate_poses();
  JcsdLikelihood jcsd;
  PointToPointLikelihood p2p;
  for (Likelihood* likelihood : std::initializer_list<Likelihood*>{&jcsd, &p2p}) {
    likelihood->set_model(scene.model);
    std::vector<float> scores(poses.size());
    likelihood->evaluate(poses, data, scores);
    EXPECT_EQ(rank_of_true_pose(scores), 0u) << likelihood->name();
  }
}

TEST(Ranking, JcsdRanksTheTruePoseFirstOnAShiftedSampling) {
  // Observed points lie between the model's points. Nearest-neighbour scores reward re-aligning
  // the two samplings (a shift of a fraction of the spacing can beat the truth), so only the
  // density-based JCSD is held to this; the point-to-point rank is printed.
  const Scene scene(0.5f);
  const HypothesisData data = test::make_hypothesis(scene.observed);
  const std::vector<Pose> poses = candidate_poses();
  JcsdLikelihood jcsd;
  PointToPointLikelihood p2p;
  jcsd.set_model(scene.model);
  p2p.set_model(scene.model);
  std::vector<float> jcsd_scores(poses.size()), p2p_scores(poses.size());
  jcsd.evaluate(poses, data, jcsd_scores);
  p2p.evaluate(poses, data, p2p_scores);
  EXPECT_EQ(rank_of_true_pose(jcsd_scores), 0u);
  std::printf("shifted sampling: candidates scoring >= true pose: JCSD %zu, point-to-point %zu of %zu\n",
              rank_of_true_pose(jcsd_scores), rank_of_true_pose(p2p_scores), poses.size() - 1);
}

TEST(Ranking, JcsdKeepsTheTruePoseFirstUnderFortyPercentOcclusion) {
  const Scene scene;
  const std::vector<Pose> poses = candidate_poses();
  JcsdLikelihood jcsd;
  PointToPointLikelihood p2p;
  jcsd.set_model(scene.model);
  p2p.set_model(scene.model);
  // Four occluder directions in the camera frame; each hides the 40 % of points farthest along it.
  for (const Eigen::Vector3f& direction : {Eigen::Vector3f(1.f, 0.f, 0.f), Eigen::Vector3f(-1.f, 0.f, 0.f),
                                           Eigen::Vector3f(0.f, 1.f, 0.f), Eigen::Vector3f(1.f, -1.f, 0.5f)}) {
    const HypothesisData data = test::make_hypothesis(test::occluded(scene.observed, direction.normalized(), 0.4f));
    ASSERT_NEAR(static_cast<float>(data.points.size()), 0.6f * scene.observed.size(), 2.f);
    std::vector<float> jcsd_scores(poses.size()), p2p_scores(poses.size());
    jcsd.evaluate(poses, data, jcsd_scores);
    p2p.evaluate(poses, data, p2p_scores);
    EXPECT_EQ(rank_of_true_pose(jcsd_scores), 0u) << "occluder " << direction.transpose();
    std::printf(
        "40%% occlusion along (%+.1f %+.1f %+.1f): candidates scoring >= true pose: JCSD %zu, point-to-point %zu of "
        "%zu\n",
        direction.x(), direction.y(), direction.z(), rank_of_true_pose(jcsd_scores), rank_of_true_pose(p2p_scores),
        poses.size() - 1);
  }
}

TEST(PointToPointLikelihood, ScoresCountCloseAndSimilarlyColouredPairs) {
  // One model point (black), one data point 4 mm away in pure blue: d_c = |(0,0,1)| = 1.
  // score = exp(-200 * 0.004) exp(-2 * 1) = exp(-0.8) exp(-2) = 0.449329 * 0.135335 = 0.060810.
  ObjectModel model;
  model.cloud.push_back(Eigen::Vector3f::Zero(), Rgb8{0, 0, 0});
  model.features = compute_smr(model.cloud.colors);
  PointToPointLikelihood p2p;
  p2p.set_model(model);
  HypothesisData data;
  data.points = {Eigen::Vector3f(0.004f, 0.f, 0.f), Eigen::Vector3f(0.05f, 0.f, 0.f)};  // second: no partner
  data.colors = {Rgb8{0, 0, 255}, Rgb8{0, 0, 0}};
  data.features = compute_smr(data.colors);
  const std::vector<Pose> poses(1);
  std::vector<float> scores(1);
  p2p.evaluate(poses, data, scores);
  EXPECT_NEAR(scores[0], 0.060810f, 1e-5f);
}

TEST(PointToPointLikelihood, InvalidOptionsThrow) {
  EXPECT_THROW(PointToPointLikelihood(PointToPointOptions{-1.f, 2.f, 0.01f}), std::invalid_argument);
  EXPECT_THROW(PointToPointLikelihood(PointToPointOptions{200.f, -2.f, 0.01f}), std::invalid_argument);
  EXPECT_THROW(PointToPointLikelihood(PointToPointOptions{200.f, 2.f, 0.f}), std::invalid_argument);
}

TEST(HypothesisSelection, KeepsPointsInTheGrownOrientedBox) {
  const Scene scene;
  ColoredCloud frame = scene.observed;
  const std::size_t object_points = frame.size();
  const Eigen::Isometry3f to_camera = kTruePose.isometry();
  // Object-frame box: x in +-5 cm, y in +-7.5 cm, z in +-4 cm; margin 2 cm.
  frame.push_back(to_camera * Eigen::Vector3f(0.065f, 0.f, 0.f), Rgb8{1, 2, 3});  // 1.5 cm out: kept
  frame.push_back(to_camera * Eigen::Vector3f(0.f, 0.f, 0.065f), Rgb8{1, 2, 3});  // 2.5 cm out: dropped
  frame.push_back(to_camera * Eigen::Vector3f(0.06f, 0.1f, 0.f), Rgb8{1, 2, 3});  // y 2.5 cm out: dropped
  frame.push_back(Eigen::Vector3f(1.f, 1.f, 1.f), Rgb8{1, 2, 3});                 // far away: dropped
  const std::vector<SmrFeature> features = compute_smr(frame.colors);
  HypothesisData out;
  out.points.resize(3);  // stale content must be cleared
  select_hypothesis_data(frame, features, scene.model, kTruePose, HypothesisOptions{0.02f}, out);
  ASSERT_EQ(out.points.size(), object_points + 1);
  ASSERT_EQ(out.features.size(), out.points.size());
  ASSERT_EQ(out.colors.size(), out.points.size());
  EXPECT_EQ(out.points.back(), frame.positions[object_points]);
  EXPECT_EQ(out.colors.front(), frame.colors.front());
  EXPECT_THROW(select_hypothesis_data(frame, features, scene.model, kTruePose, HypothesisOptions{-0.1f}, out),
               std::invalid_argument);
  EXPECT_THROW(select_hypothesis_data(frame, std::span<const SmrFeature>(features).first(3), scene.model, kTruePose,
                                      HypothesisOptions{}, out),
               std::invalid_argument);
}

}  // namespace
}  // namespace mfot
