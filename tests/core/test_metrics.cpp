#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <tuple>
#include <vector>

#include "mfot/metrics.hpp"

namespace mfot {
namespace {

// A square patch in the object frame's z = 0 plane, side n * step, centred at the origin.
std::vector<Eigen::Vector3f> patch(int n, float step) {
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      points.emplace_back((static_cast<float>(i) - 0.5f * static_cast<float>(n - 1)) * step,
                          (static_cast<float>(j) - 0.5f * static_cast<float>(n - 1)) * step, 0.f);
  return points;
}

Pose pose_at(const Eigen::Vector3f& t, float angle = 0.f, const Eigen::Vector3f& axis = Eigen::Vector3f::UnitZ()) {
  Pose p;
  p.translation = t;
  p.rotation = Eigen::Quaternionf(Eigen::AngleAxisf(angle, axis.normalized()));
  return p;
}

std::vector<Eigen::Vector3f> transformed(const std::vector<Eigen::Vector3f>& points, const Pose& pose) {
  std::vector<Eigen::Vector3f> out;
  for (const auto& p : points) out.push_back(pose.isometry() * p);
  return out;
}

FittingDistanceOptions fitting_options(bool occlusion_test) {
  FittingDistanceOptions o;
  o.occlusion_test = occlusion_test;
  return o;
}

TEST(FittingDistance, RejectsInvalidOptions) {
  FittingDistanceOptions o;
  o.occlusion_window = 0.f;
  EXPECT_THROW(FittingDistanceEvaluator{o}, std::invalid_argument);
  o = FittingDistanceOptions{};
  o.depth_margin = -1.f;
  EXPECT_THROW(FittingDistanceEvaluator{o}, std::invalid_argument);
}

TEST(FittingDistance, ZeroForAModelOnItsOwnPoints) {
  const auto model = patch(20, 0.005f);
  const Pose pose = pose_at({0.05f, -0.02f, 0.9f}, 0.5f, {1.f, 0.2f, 0.f});
  FittingDistanceEvaluator evaluator;
  evaluator.set_scene(transformed(model, pose));
  const FittingDistance d = evaluator.evaluate(model, pose);
  EXPECT_EQ(d.model_points, model.size());
  EXPECT_EQ(d.occluded, 0u);
  EXPECT_NEAR(d.mean, 0.0, 1e-6);
}

TEST(FittingDistance, MeasuresAKnownOffset) {
  // The scene is the same patch 3 mm closer to the camera: every model point is 3 mm from its
  // nearest scene point and, 3 mm being under the depth margin, none counts as occluded.
  const auto model = patch(20, 0.005f);
  const Pose pose = pose_at({0.f, 0.f, 1.f});
  FittingDistanceEvaluator evaluator;
  evaluator.set_scene(transformed(model, pose_at({0.f, 0.f, 0.997f})));
  const FittingDistance d = evaluator.evaluate(model, pose);
  EXPECT_EQ(d.occluded, 0u);
  EXPECT_NEAR(d.mean, 0.003, 1e-6);
}

TEST(FittingDistance, EveryPointsDistanceIsToItsNearestScenePointAtAnyRange) {
  // Model points from 1 mm to 60 cm from a sparse scene, so the nearest lies inside each of the
  // search's growing radii and beyond the last bounded one; without the occlusion test the mean is
  // the brute-force mean of each model point's nearest scene distance.
  std::vector<Eigen::Vector3f> scene;
  for (int i = 0; i < 40; ++i)
    scene.emplace_back(0.013f * static_cast<float>(i % 7), 0.021f * static_cast<float>(i / 7), 1.f);
  std::vector<Eigen::Vector3f> model;
  for (int i = 0; i < 60; ++i) {
    const float reach = 0.001f * std::pow(1.12f, static_cast<float>(i));  // 1 mm .. about 0.8 m
    model.emplace_back(0.05f + reach * std::cos(0.7f * static_cast<float>(i)),
                       0.04f + reach * std::sin(0.7f * static_cast<float>(i)), 1.f + 0.3f * reach);
  }
  FittingDistanceEvaluator evaluator(fitting_options(false));
  evaluator.set_scene(scene);
  double expected = 0.0;
  for (const auto& m : model) {
    float best = std::numeric_limits<float>::infinity();
    for (const auto& q : scene) best = std::min(best, (q - m).squaredNorm());
    expected += std::sqrt(static_cast<double>(best));
  }
  expected /= static_cast<double>(model.size());
  const FittingDistance d = evaluator.evaluate(model, Pose{});
  EXPECT_EQ(d.occluded, 0u);
  EXPECT_DOUBLE_EQ(d.mean, expected);
}

TEST(FittingDistance, OccludedModelPointsCountAsZero) {
  // Model: a 21 x 21 patch, 5 mm spacing, p.x in {-0.05, ..., 0.05}, estimated at 1 m but 2 cm
  // right of its true place, so the estimated columns are x = -0.03 ... 0.07. Scene: the true
  // patch's columns x < 0 (-0.05 ... -0.005, at 1 m), and an occluder at 0.7 m covering the rays
  // with x / z in [0.025, 0.08] (points every 0.003 in the normalised image plane).
  const auto model = patch(21, 0.005f);
  std::vector<Eigen::Vector3f> scene;
  for (const auto& p : model) {
    if (p.x() < 0.f) scene.push_back(p + Eigen::Vector3f(0.f, 0.f, 1.f));
  }
  for (int i = 0; i <= 18; ++i) {
    for (int j = -20; j <= 20; ++j) {
      const float u = 0.025f + 0.003f * static_cast<float>(i), v = 0.003f * static_cast<float>(j);
      scene.emplace_back(u * 0.7f, v * 0.7f, 0.7f);
    }
  }
  const Pose estimate = pose_at({0.02f, 0.f, 1.f});
  FittingDistanceEvaluator with_test(fitting_options(true));
  with_test.set_scene(scene);
  const FittingDistance d = with_test.evaluate(model, estimate);
  // Occluded: the columns x >= 0.025, and x = 0.02 whose rays pass 0.005 < 0.006 (the window)
  // from the occluder's edge: 11 columns of 21.
  EXPECT_EQ(d.occluded, 11u * 21u);
  // Visible: columns x <= -0.005 lie on scene points (0); columns 0, 0.005, 0.01, 0.015 are
  // 5, 10, 15, 20 mm from the scene column x = -0.005: 21 * 0.05 m over 441 points.
  EXPECT_NEAR(d.mean, 21.0 * 0.05 / 441.0, 1e-5);

  // Without the test the 11 occluded columns add their distances 25, 30, ..., 75 mm to the
  // scene column x = -0.005 (the occluder is farther): 21 * (0.05 + 0.55) m over 441 points.
  FittingDistanceEvaluator without_test(fitting_options(false));
  without_test.set_scene(scene);
  const FittingDistance plain = without_test.evaluate(model, estimate);
  EXPECT_EQ(plain.occluded, 0u);
  EXPECT_NEAR(plain.mean, 21.0 * 0.6 / 441.0, 1e-5);
}

TEST(FittingDistance, PointsBehindTheCameraAreOccludedAndAnEmptySceneIsInfinite) {
  const std::vector<Eigen::Vector3f> model = {{0.f, 0.f, -0.5f}, {0.f, 0.f, 0.5f}};
  FittingDistanceEvaluator evaluator;
  evaluator.set_scene(std::vector<Eigen::Vector3f>{{0.f, 0.f, 0.51f}});
  const FittingDistance d = evaluator.evaluate(model, Pose{});
  EXPECT_EQ(d.occluded, 1u);
  EXPECT_NEAR(d.mean, 0.01 / 2.0, 1e-6);
  evaluator.set_scene({});
  EXPECT_TRUE(std::isinf(evaluator.evaluate(model, Pose{}).mean));
}

TEST(SegmentationAccuracy, PerfectAndPermutedLabellingsScoreOne) {
  const std::vector<std::int32_t> truth = {0, 0, 1, 1, 1, 2, 2, 3};
  SegmentationAccuracy perfect;
  perfect.add_frame(truth, truth);
  perfect.add_frame(truth, truth);
  EXPECT_DOUBLE_EQ(perfect.accuracy(), 1.0);
  EXPECT_EQ(perfect.points(), 16u);
  EXPECT_EQ(perfect.frames(), 2u);

  const std::vector<std::int32_t> permuted = {0, 0, 7, 7, 7, 5, 5, 12};
  SegmentationAccuracy renamed;
  renamed.add_frame(permuted, truth);
  EXPECT_DOUBLE_EQ(renamed.accuracy(), 1.0);
  const auto map = renamed.mapping();
  EXPECT_EQ(map.at(0), 0);
  EXPECT_EQ(map.at(7), 1);
  EXPECT_EQ(map.at(5), 2);
  EXPECT_EQ(map.at(12), 3);
}

TEST(SegmentationAccuracy, KnownMislabelling) {
  // Frame 1 (10 points): truth 0 0 0 1 1 1 1 2 2 2
  //                      pred  0 0 5 5 5 5 8 8 8 0
  // Frame 2 (6 points):  truth 1 1 1 2 2 0
  //                      pred  8 8 5 8 8 8
  // Overlaps over both frames: (5,1) = 3 + 1 = 4, (8,2) = 2 + 2 = 4, (8,1) = 1 + 2 = 3,
  // (5,0) = 1, (0,2) = 1, (8,0) = 1. Greedy: (5,1) and (8,2) tie at 4 and both are taken;
  // (8,1) loses (8 taken). Correct: (0,0) 2 + (5,1) 4 + (8,2) 4 = 10 of 16.
  SegmentationAccuracy acc;
  acc.add_frame(std::vector<std::int32_t>{0, 0, 5, 5, 5, 5, 8, 8, 8, 0},
                std::vector<std::int32_t>{0, 0, 0, 1, 1, 1, 1, 2, 2, 2});
  acc.add_frame(std::vector<std::int32_t>{8, 8, 5, 8, 8, 8}, std::vector<std::int32_t>{1, 1, 1, 2, 2, 0});
  EXPECT_DOUBLE_EQ(acc.accuracy(), 10.0 / 16.0);
  const auto map = acc.mapping();
  EXPECT_EQ(map.at(5), 1);
  EXPECT_EQ(map.at(8), 2);
  // Frame 1: (0,0) 2 + (5,1) 3 + (8,2) 2 = 7 of 10; frame 2: (5,1) 1 + (8,2) 2 = 3 of 6.
  const auto per_frame = acc.frame_accuracies();
  ASSERT_EQ(per_frame.size(), 2u);
  EXPECT_DOUBLE_EQ(per_frame[0], 0.7);
  EXPECT_DOUBLE_EQ(per_frame[1], 0.5);
}

// Where the points of KnownMislabelling went: every (predicted, ground truth) pair with its points
// over both frames and the frames it occurs in.
TEST(SegmentationAccuracy, OverlapsCountEveryPairsPointsAndFrames) {
  SegmentationAccuracy acc;
  acc.add_frame(std::vector<std::int32_t>{0, 0, 5, 5, 5, 5, 8, 8, 8, 0},
                std::vector<std::int32_t>{0, 0, 0, 1, 1, 1, 1, 2, 2, 2});
  acc.add_frame(std::vector<std::int32_t>{8, 8, 5, 8, 8, 8}, std::vector<std::int32_t>{1, 1, 1, 2, 2, 0});
  const auto overlaps = acc.overlaps();
  std::vector<std::tuple<std::int32_t, std::int32_t, std::uint64_t, std::size_t>> got;
  std::uint64_t total = 0;
  for (const auto& o : overlaps) {
    got.emplace_back(o.predicted, o.ground_truth, o.points, o.frames);
    total += o.points;
  }
  const std::vector<std::tuple<std::int32_t, std::int32_t, std::uint64_t, std::size_t>> expected{
      {0, 0, 2, 1}, {0, 2, 1, 1}, {5, 0, 1, 1}, {5, 1, 4, 2}, {8, 0, 1, 1}, {8, 1, 3, 2}, {8, 2, 4, 2}};
  EXPECT_EQ(got, expected);
  EXPECT_EQ(total, acc.points());
  EXPECT_TRUE(SegmentationAccuracy().overlaps().empty());
}

TEST(SegmentationAccuracy, OneToOneLeavesExtraPredictionsWrong) {
  // Object 1 is split into predictions 4 (5 points) and 6 (3 points): 6 stays unmatched.
  const std::vector<std::int32_t> truth = {1, 1, 1, 1, 1, 1, 1, 1, 0, 0};
  const std::vector<std::int32_t> pred = {4, 4, 4, 4, 4, 6, 6, 6, 0, 0};
  SegmentationAccuracy acc;
  acc.add_frame(pred, truth);
  EXPECT_DOUBLE_EQ(acc.accuracy(), 7.0 / 10.0);
  EXPECT_EQ(acc.mapping().at(6), SegmentationAccuracy::kUnmatched);
  // Predicting an object where there is only background is wrong as well.
  SegmentationAccuracy phantom;
  phantom.add_frame(std::vector<std::int32_t>{3, 3, 0}, std::vector<std::int32_t>{0, 0, 0});
  EXPECT_DOUBLE_EQ(phantom.accuracy(), 1.0 / 3.0);
  EXPECT_THROW(acc.add_frame(pred, std::vector<std::int32_t>{1}), std::invalid_argument);
}

TEST(RelativePoseError, ZeroForIdenticalTrajectoriesAndAnyObjectFrame) {
  std::vector<Pose> truth;
  for (int t = 0; t < 10; ++t) {
    truth.push_back(
        pose_at({0.01f * static_cast<float>(t), 0.1f, 0.8f}, 0.1f * static_cast<float>(t), {1.f, 1.f, 0.f}));
  }
  // The tracker's object frame differs from the ground truth's by a constant offset O.
  const Eigen::Isometry3f offset = pose_at({0.02f, -0.03f, 0.01f}, 0.6f, {0.f, 1.f, 1.f}).isometry();
  std::vector<Pose> predicted;
  for (const auto& g : truth) predicted.push_back(Pose::from_isometry(g.isometry() * offset));
  for (const auto* trajectory : {&truth, &predicted}) {
    const auto errors = relative_pose_errors(*trajectory, truth);
    ASSERT_EQ(errors.size(), truth.size());
    for (const auto& e : errors) {
      EXPECT_NEAR(e.translation_mm, 0.0, 0.01);
      EXPECT_NEAR(e.rotation_deg, 0.0, 0.01);
    }
  }
  EXPECT_THROW(relative_pose_errors(truth, std::span<const Pose>(truth).first(3)), std::invalid_argument);
}

TEST(RelativePoseError, KnownOffset) {
  // Ground truth: the object slides along x. Prediction: from frame 1 on, 3 mm + 4 mm off in
  // (x, y) and turned 10 degrees further about the camera z axis through its own position.
  std::vector<Pose> truth, predicted;
  for (int t = 0; t < 3; ++t) {
    const Pose g = pose_at({0.05f * static_cast<float>(t), 0.f, 0.8f});
    truth.push_back(g);
    Pose p = g;
    if (t > 0) {
      p.translation += Eigen::Vector3f(0.003f, 0.004f, 0.f);
      p.rotation =
          Eigen::Quaternionf(Eigen::AngleAxisf(10.f * std::numbers::pi_v<float> / 180.f, Eigen::Vector3f::UnitZ())) *
          p.rotation;
    }
    predicted.push_back(p);
  }
  const auto errors = relative_pose_errors(predicted, truth);
  EXPECT_NEAR(errors[0].translation_mm, 0.0, 1e-6);
  // Motion translation: t_t - R_t R_t0^T t_t0 with t_t0 = (0, 0, 0.8) on the rotation axis, so
  // the extra rotation adds nothing: the error is the 5 mm offset.
  for (int t = 1; t < 3; ++t) {
    EXPECT_NEAR(errors[static_cast<std::size_t>(t)].translation_mm, 5.0, 1e-3);
    EXPECT_NEAR(errors[static_cast<std::size_t>(t)].rotation_deg, 10.0, 1e-3);
  }
}

TEST(RelativePoseError, RotationErrorAboutTheObjectDoesNotCountAsTranslation) {
  // Ground truth: a static object 1 m in front of the camera. Prediction: the same position,
  // turned 1 degree about the object's own centre. The object's centre does not move, so the
  // translation error is 0; the camera origin, 1 m away, is carried 1 m x 1 deg = 17.45 mm.
  std::vector<Pose> truth(2, pose_at({0.f, 0.f, 1.f}));
  std::vector<Pose> predicted = truth;
  predicted[1].rotation =
      Eigen::Quaternionf(Eigen::AngleAxisf(std::numbers::pi_v<float> / 180.f, Eigen::Vector3f::UnitY())) *
      predicted[1].rotation;
  const auto errors = relative_pose_errors(predicted, truth);
  EXPECT_NEAR(errors[1].translation_mm, 0.0, 1e-3);
  EXPECT_NEAR(errors[1].rotation_deg, 1.0, 1e-3);
  EXPECT_NEAR(errors[1].translation_at_camera_mm, 1000.0 * 2.0 * std::sin(std::numbers::pi / 360.0), 1e-2);
}

TEST(RelativePoseError, Summary) {
  const std::vector<PoseError> errors = {{2.0, 1.0}, {12.0, 0.5}, {4.0, 6.0}, {30.0, 2.0}};
  const PoseErrorSummary s = summarize(errors);
  EXPECT_EQ(s.count, 4u);
  EXPECT_DOUBLE_EQ(s.translation_mean_mm, 12.0);
  EXPECT_DOUBLE_EQ(s.translation_median_mm, 8.0);
  EXPECT_DOUBLE_EQ(s.translation_max_mm, 30.0);
  EXPECT_DOUBLE_EQ(s.rotation_mean_deg, 2.375);
  EXPECT_DOUBLE_EQ(s.rotation_median_deg, 1.5);
  EXPECT_DOUBLE_EQ(s.rotation_max_deg, 6.0);
  EXPECT_DOUBLE_EQ(s.share_translation_over, 0.5);
  EXPECT_DOUBLE_EQ(s.share_rotation_over, 0.25);
  EXPECT_DOUBLE_EQ(s.share_either_over, 0.75);
  EXPECT_EQ(summarize(std::span<const PoseError>{}).count, 0u);
}

}  // namespace
}  // namespace mfot

namespace mfot {
namespace {

TEST(SegmentMatch, CountsFoundMergedSplitAndSpurious) {
  // Segments 1 (4 points), 2 (4), 3 (4) and background (0, 4 points).
  const std::vector<std::int32_t> truth{1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3, 0, 0, 0, 0};
  // Object 10 is segment 1 exactly; 20 holds segments 2 and 3's first half (merged);
  // 30 and 40 hold a point of segment 3 each; 50 lies on background.
  const std::vector<std::int32_t> predicted{10, 10, 10, 10, 20, 20, 20, 20, 20, 20, 30, 40, 50, 50, 50, 0};
  const SegmentMatch m = match_segments(truth, predicted);
  EXPECT_EQ(m.segments, 3u);
  EXPECT_EQ(m.objects, 5u);
  // IoU: 1 -> 10 = 1; 2 -> 20 = 4/6; 3 -> 20 = 2/8, 30 = 1/4, 40 = 1/4.
  EXPECT_EQ(m.found, 2u);
  EXPECT_NEAR(m.weighted_overlap, (4 * 1.0 + 4 * (4.0 / 6.0) + 4 * 0.25) / 12.0, 1e-12);
  EXPECT_EQ(m.merged, 1u);    // segment 3's largest object (20) holds all of segment 2
  EXPECT_EQ(m.split, 1u);     // segment 3: 20, 30 and 40 each hold >= 20 %
  EXPECT_EQ(m.spurious, 1u);  // 50
}

TEST(SegmentMatch, PerfectAndEmpty) {
  const std::vector<std::int32_t> truth{1, 1, 2, 2, 0};
  const SegmentMatch perfect = match_segments(truth, std::vector<std::int32_t>{7, 7, 9, 9, 0});
  EXPECT_EQ(perfect.found, 2u);
  EXPECT_DOUBLE_EQ(perfect.weighted_overlap, 1.0);
  EXPECT_EQ(perfect.merged + perfect.split + perfect.spurious, 0u);
  const SegmentMatch none = match_segments(truth, std::vector<std::int32_t>(5, 0));
  EXPECT_EQ(none.found, 0u);
  EXPECT_DOUBLE_EQ(none.weighted_overlap, 0.0);
  EXPECT_THROW(match_segments(truth, std::vector<std::int32_t>(4, 0)), std::invalid_argument);
  SegmentMatchOptions bad;
  bad.found_iou = 0.0;
  EXPECT_THROW(match_segments(truth, truth, bad), std::invalid_argument);
}

}  // namespace
}  // namespace mfot

namespace mfot {
namespace {

TEST(RelativePoseErrors, AnObjectsSymmetryAxisLeavesTheTurnAboutItOut) {
  // A can standing at 1 m, its axis the object z axis (camera frame: the can's axis is camera y).
  Pose start;
  start.translation = Eigen::Vector3f(0.f, 0.f, 1.f);
  start.rotation = Eigen::Quaternionf(Eigen::AngleAxisf(0.5f * std::numbers::pi_v<float>, Eigen::Vector3f::UnitX()));
  const Eigen::Vector3f axis = Eigen::Vector3f::UnitZ();
  // Truth: still. Prediction 1: turned 30 deg about the can's own axis; 2: tilted 10 deg.
  const auto turned = [&](const Eigen::Vector3f& camera_axis, float degrees) {
    Pose p = start;
    p.rotation = Eigen::Quaternionf(Eigen::AngleAxisf(degrees * std::numbers::pi_v<float> / 180.f, camera_axis)) *
                 start.rotation;
    return p;
  };
  const Eigen::Vector3f can_axis_in_camera = start.rotation * axis;
  const std::vector<Pose> truth{start, start, start};
  const std::vector<Pose> predicted{start, turned(can_axis_in_camera, 30.f), turned(Eigen::Vector3f::UnitZ(), 10.f)};
  const auto errors = relative_pose_errors(predicted, truth, axis);
  EXPECT_NEAR(errors[1].rotation_deg, 30.0, 1e-3);
  EXPECT_NEAR(errors[1].observable_rotation_deg, 0.0, 1e-3);
  EXPECT_NEAR(errors[2].rotation_deg, 10.0, 1e-3);
  EXPECT_NEAR(errors[2].observable_rotation_deg, 10.0, 1e-3);
  // Without an axis the observable error is the whole one.
  const auto plain = relative_pose_errors(predicted, truth);
  EXPECT_DOUBLE_EQ(plain[1].observable_rotation_deg, plain[1].rotation_deg);
  const PoseErrorSummary s = summarize(std::span<const PoseError>(errors).subspan(1));
  EXPECT_NEAR(s.observable_rotation_max_deg, 10.0, 1e-3);
  EXPECT_NEAR(s.rotation_max_deg, 30.0, 1e-3);
}

}  // namespace
}  // namespace mfot
