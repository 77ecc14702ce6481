#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <numbers>
#include <random>
#include <stdexcept>
#include <vector>

#include "expect_invalid_argument.hpp"
#include "mfot/icp_refinement.hpp"
#include "mfot/particle_filter.hpp"
#include "mfot/smr_feature.hpp"
#include "synthetic_object.hpp"

namespace mfot {
namespace {

const Eigen::Vector3f kSize(0.10f, 0.15f, 0.08f);

// The test box at 5 mm spacing 1 m in front of the camera, turned so three faces show; the scene is
// its near side sampled between the model's points (phase 0.5), as a sensor samples a surface
// elsewhere than the model's voxels.
struct SeenBox {
  ColoredCloud model = test::make_test_object(0.f, 0.005f);
  Pose truth = test::make_pose(Eigen::Vector3f(0.05f, -0.02f, 1.f), Eigen::Vector3f(0.4f, 1.f, 0.2f), 0.7f);
  ColoredCloud scene = test::seen_from_origin(test::make_test_object(0.5f, 0.005f), kSize, truth);
  // The truth moved by 4 mm and turned by 4 degrees about an oblique axis: a lagging estimate.
  Pose start() const {
    Pose p = truth;
    p.translation += Eigen::Vector3f(0.003f, -0.002f, 0.0015f);
    p.rotation =
        (Eigen::Quaternionf(Eigen::AngleAxisf(test::radians(4.f), Eigen::Vector3f(1.f, 0.5f, 0.3f).normalized())) *
         p.rotation)
            .normalized();
    return p;
  }
};

IcpRefinementOptions iterations(int n) {
  IcpRefinementOptions o;
  o.iterations = n;
  return o;
}

TEST(IcpRefinement, PullsALaggingEstimateOntoTheSurface) {
  const SeenBox box;
  const Pose start = box.start();
  IcpRefinement icp(iterations(10));
  const IcpResult r = icp.refine(box.scene.positions, box.model.positions, start);
  ASSERT_TRUE(r.refined);
  EXPECT_EQ(r.sampled, 350u);  // every 4th of 1400 scene points: at most max_points (400)
  EXPECT_GT(r.paired, r.sampled * 9 / 10);
  std::printf("ICP from %.1f mm / %.1f deg: %.2f mm / %.2f deg (%zu of %zu sampled scene points paired)\n",
              1e3f * test::translation_error(start, box.truth), test::degrees(test::rotation_error(start, box.truth)),
              1e3f * test::translation_error(r.pose, box.truth), test::degrees(test::rotation_error(r.pose, box.truth)),
              r.paired, r.sampled);
  // Point-to-point pairs slide a little along flat faces sampled elsewhere than the model (1.2 mm,
  // 0.64 degrees left here): within a third of the start's error.
  EXPECT_LT(test::translation_error(r.pose, box.truth), 0.0015f);
  EXPECT_LT(test::degrees(test::rotation_error(r.pose, box.truth)), 1.f);
  // Deterministic: the same call gives the same pose.
  const IcpResult again = icp.refine(box.scene.positions, box.model.positions, start);
  EXPECT_EQ(again.pose.translation, r.pose.translation);
  EXPECT_EQ(again.pose.rotation.coeffs(), r.pose.rotation.coeffs());
}

TEST(IcpRefinement, KeepsTheStartWhenTooFewPointsPair) {
  const SeenBox box;
  const Pose start = box.start();
  // Half of the scene is a wall 20 cm behind the box: below the paired share needed.
  ColoredCloud scene = box.scene;
  const std::size_t box_points = scene.size();
  for (std::size_t k = 0; k < box_points + 10; ++k) {
    scene.push_back(Eigen::Vector3f(0.002f * static_cast<float>(k % 100), 0.002f * static_cast<float>(k / 100), 1.3f),
                    test::kWhite);
  }
  IcpRefinement icp(iterations(5));
  const IcpResult r = icp.refine(scene.positions, box.model.positions, start);
  EXPECT_FALSE(r.refined);
  EXPECT_EQ(r.pose.translation, start.translation);
  EXPECT_EQ(r.pose.rotation.coeffs(), start.rotation.coeffs());
  EXPECT_LT(r.paired, r.sampled / 2);
  // With a lower share it refines on the box's points and ignores the wall (beyond max_distance).
  IcpRefinementOptions lenient = iterations(10);
  lenient.min_paired_share = 0.3f;
  IcpRefinement lenient_icp(lenient);
  const IcpResult l = lenient_icp.refine(scene.positions, box.model.positions, start);
  ASSERT_TRUE(l.refined);
  EXPECT_LT(test::degrees(test::rotation_error(l.pose, box.truth)), 1.f);
  // Nothing to pair with: an empty scene or model, or no iterations.
  EXPECT_FALSE(icp.refine({}, box.model.positions, start).refined);
  EXPECT_FALSE(icp.refine(box.scene.positions, {}, start).refined);
  IcpRefinement off(iterations(0));
  EXPECT_FALSE(off.refine(box.scene.positions, box.model.positions, start).refined);
}

// The box seen with 3 mm of depth noise (seeded draws): a 20-point sample leaves the fit's noise in the
// estimate; the same iterations on every point (max_points 2000, the services' constant) average it out.
TEST(IcpRefinement, ADenseSampleAveragesTheNoiseOut) {
  const SeenBox box;
  const Pose start = box.start();
  IcpRefinementOptions sparse = iterations(10);
  sparse.max_points = 20;
  sparse.min_paired_share = 0.f;
  IcpRefinementOptions dense = sparse;
  dense.max_points = 2000;
  IcpRefinement sparse_icp(sparse);
  IcpRefinement dense_icp(dense);
  constexpr int kDraws = 8;
  float sparse_deg = 0.f, dense_deg = 0.f, sparse_worst = 0.f, dense_worst = 0.f;
  for (int draw = 0; draw < kDraws; ++draw) {
    ColoredCloud noisy = box.scene;
    std::mt19937 generator(static_cast<std::uint32_t>(draw));
    std::normal_distribution<float> noise(0.f, 0.003f);
    for (Eigen::Vector3f& p : noisy.positions) p *= 1.f + noise(generator) / p.norm();
    const IcpResult s = sparse_icp.refine(noisy.positions, box.model.positions, start);
    const IcpResult d = dense_icp.refine(noisy.positions, box.model.positions, start);
    ASSERT_TRUE(s.refined);
    ASSERT_TRUE(d.refined);
    EXPECT_EQ(s.sampled, 20u);
    EXPECT_EQ(d.sampled, noisy.size());  // every point (fewer than max_points)
    const float s_deg = test::degrees(test::rotation_error(s.pose, box.truth));
    const float d_deg = test::degrees(test::rotation_error(d.pose, box.truth));
    sparse_deg += s_deg / kDraws;
    dense_deg += d_deg / kDraws;
    sparse_worst = std::max(sparse_worst, s_deg);
    dense_worst = std::max(dense_worst, d_deg);
  }
  std::printf(
      "3 mm noise, %d draws, 10 iterations on 20 points: %.2f deg mean, %.2f worst; on every point: "
      "%.2f deg mean, %.2f worst\n",
      kDraws, sparse_deg, sparse_worst, dense_deg, dense_worst);
  EXPECT_LT(dense_worst, 1.5f);
  EXPECT_LT(dense_deg, 0.7f * sparse_deg);
  EXPECT_LT(dense_worst, sparse_worst);
}

// The box grown from a first view: one of the faces the camera sees was added later with a pose 6 degrees
// off (turned about the box's centre), as a growth during a fast turn adds it; the first view is the rest.
struct GrownBox {
  SeenBox box;
  ColoredCloud first_view;
  ColoredCloud grown;
  GrownBox() {
    const Eigen::Vector3f half = 0.5f * kSize;
    // The visible face with the most points: its outward normal faces the camera at the truth.
    int grown_face = -1;
    std::size_t most = 0;
    for (int face = 0; face < 6; ++face) {
      Eigen::Vector3f normal = Eigen::Vector3f::Zero();
      normal[face / 2] = face % 2 == 0 ? -1.f : 1.f;
      const Eigen::Vector3f centre = box.truth.isometry() * Eigen::Vector3f(normal.cwiseProduct(half));
      if ((box.truth.rotation * normal).dot(centre) >= 0.f) continue;
      std::size_t count = 0;
      for (const Eigen::Vector3f& p : box.model.positions) count += on_face(p, face) ? 1 : 0;
      if (count > most) {
        most = count;
        grown_face = face;
      }
    }
    const Eigen::Matrix3f off =
        Eigen::AngleAxisf(test::radians(6.f), Eigen::Vector3f(0.3f, 1.f, -0.4f).normalized()).toRotationMatrix();
    ColoredCloud added;
    for (std::size_t k = 0; k < box.model.size(); ++k) {
      const Eigen::Vector3f& p = box.model.positions[k];
      if (on_face(p, grown_face)) {
        added.push_back(off * p, box.model.colors[k]);
      } else {
        first_view.push_back(p, box.model.colors[k]);
      }
    }
    grown = first_view;  // growth appends
    for (std::size_t k = 0; k < added.size(); ++k) grown.push_back(added.positions[k], added.colors[k]);
  }
  static bool on_face(const Eigen::Vector3f& p, int face) {
    const float side = face % 2 == 0 ? -1.f : 1.f;
    return std::abs(p[face / 2] - side * 0.5f * kSize[face / 2]) < 1e-4f;
  }
};

TEST(IcpRefinement, TheFirstViewAnchorsTheFrameAgainstAGrownFacesError) {
  const GrownBox g;
  const Pose start = g.box.start();
  const auto refine_grown = [&](float anchor_weight) {
    IcpRefinementOptions o = iterations(20);
    o.anchor_weight = anchor_weight;
    IcpRefinement icp(o);
    icp.refine(g.box.scene.positions, g.first_view.positions, start);  // the object's first model
    const IcpResult r = icp.refine(g.box.scene.positions, g.grown.positions, start);
    EXPECT_TRUE(r.refined);
    return r;
  };
  const IcpResult alike = refine_grown(1.f);
  const IcpResult anchored = refine_grown(10.f);
  const float alike_deg = test::degrees(test::rotation_error(alike.pose, g.box.truth));
  const float anchored_deg = test::degrees(test::rotation_error(anchored.pose, g.box.truth));
  std::printf(
      "a face grown 6 deg off: all points alike %.2f deg / %.2f mm off, the first view weighing 10: %.2f deg / "
      "%.2f mm\n",
      alike_deg, 1e3f * test::translation_error(alike.pose, g.box.truth), anchored_deg,
      1e3f * test::translation_error(anchored.pose, g.box.truth));
  EXPECT_GT(alike_deg, 1.5f);  // the grown face pulls the fit
  EXPECT_LT(anchored_deg, 0.5f * alike_deg);
  EXPECT_LT(anchored_deg, 1.f);

  // Without a first view before it, the grown model is the first view: every point alike.
  IcpRefinementOptions o = iterations(20);
  o.anchor_weight = 10.f;
  IcpRefinement fresh(o);
  const IcpResult first = fresh.refine(g.box.scene.positions, g.grown.positions, start);
  EXPECT_EQ(first.pose.rotation.coeffs(), alike.pose.rotation.coeffs());
  EXPECT_EQ(first.pose.translation, alike.pose.translation);
  // A model sharing no point with the first view (rebuilt in a new frame, here 1 mm over) is the new first view.
  ColoredCloud rebuilt = g.grown;
  for (Eigen::Vector3f& p : rebuilt.positions) p.x() += 0.001f;
  const IcpResult moved = fresh.refine(g.box.scene.positions, rebuilt.positions, start);
  IcpRefinement fresh_alike(iterations(20));
  const IcpResult moved_alike = fresh_alike.refine(g.box.scene.positions, rebuilt.positions, start);
  EXPECT_EQ(moved.pose.rotation.coeffs(), moved_alike.pose.rotation.coeffs());
  EXPECT_EQ(moved.pose.translation, moved_alike.pose.translation);
}

TEST(IcpRefinement, RefusesACorrectionBeyondItsLimits) {
  const SeenBox box;
  const Pose start = box.start();
  IcpRefinementOptions tight = iterations(10);
  tight.max_rotation = test::radians(2.f);  // the start is 4 degrees off
  IcpRefinement icp(tight);
  const IcpResult r = icp.refine(box.scene.positions, box.model.positions, start);
  EXPECT_FALSE(r.refined);
  EXPECT_EQ(r.pose.rotation.coeffs(), start.rotation.coeffs());
  tight = iterations(10);
  tight.max_translation = 0.002f;  // and 4 mm
  IcpRefinement short_icp(tight);
  EXPECT_FALSE(short_icp.refine(box.scene.positions, box.model.positions, start).refined);
}

// unexplained(): 0 where every scene point lies on the model, growing with the squared misplacement, 1 where
// none lies within max_distance (or nothing is given), on a stride of the scene points.
TEST(IcpRefinement, TheUnexplainedShareGrowsWithTheMisplacement) {
  const ColoredCloud model = test::make_test_object(0.f, 0.005f);
  const Pose truth = test::make_pose(Eigen::Vector3f(0.f, 0.f, 1.f), Eigen::Vector3f::UnitY(), 0.3f);
  const ColoredCloud scene = test::transformed(model, truth);  // the model's own points: distance 0
  IcpRefinement icp(iterations(5));
  const float max_distance = icp.options().max_distance;
  EXPECT_NEAR(icp.unexplained(scene.positions, model.positions, truth, 2000), 0.f, 1e-6f);
  float last = 0.f;
  for (const float shift : {0.0005f, 0.001f, 0.002f}) {  // under half the 5 mm spacing: the nearest is the same point
    Pose off = truth;
    off.translation.x() += shift;
    const float share = icp.unexplained(scene.positions, model.positions, off, 2000);
    EXPECT_NEAR(share, shift * shift / (max_distance * max_distance), 0.02f) << shift;
    EXPECT_GT(share, last);
    last = share;
  }
  Pose far = truth;
  far.translation.z() += 0.5f;
  EXPECT_EQ(icp.unexplained(scene.positions, model.positions, far, 2000), 1.f);
  Pose off = truth;
  off.translation.x() += 0.002f;
  EXPECT_NEAR(icp.unexplained(scene.positions, model.positions, off, 50),
              icp.unexplained(scene.positions, model.positions, off, 2000), 0.01f);
  EXPECT_EQ(icp.unexplained({}, model.positions, truth, 2000), 1.f);
  EXPECT_EQ(icp.unexplained(scene.positions, {}, truth, 2000), 1.f);
  EXPECT_THROW(icp.unexplained(scene.positions, model.positions, truth, 2), std::invalid_argument);
}

// A can: the side of a cylinder (radius 4 cm, height 12 cm) in eight red and blue stripes around its axis (z),
// object frame. The model's points lie on a grid about 5 mm apart; the scene's are drawn at random (seeded), as a
// sensor samples a surface elsewhere than the model's voxels.
constexpr float kCanRadius = 0.04f, kCanHeight = 0.12f;

Rgb8 stripe_colour(float angle) {
  const float turns = angle / (2.f * std::numbers::pi_v<float>);
  const int stripe = static_cast<int>(std::floor((turns - std::floor(turns)) * 8.f));
  return stripe % 2 == 0 ? test::kRed : test::kBlue;
}

Eigen::Vector3f on_can(float angle, float z) {
  return Eigen::Vector3f(kCanRadius * std::cos(angle), kCanRadius * std::sin(angle), z);
}

ColoredCloud striped_can_model() {
  constexpr float kSpacing = 0.005f;
  const int around = static_cast<int>(std::round(2.f * std::numbers::pi_v<float> * kCanRadius / kSpacing));
  ColoredCloud can;
  for (int a = 0; a < around; ++a) {
    const float angle = 2.f * std::numbers::pi_v<float> * static_cast<float>(a) / static_cast<float>(around);
    for (float z = -0.5f * kCanHeight; z <= 0.5f * kCanHeight; z += kSpacing) {
      can.push_back(on_can(angle, z), stripe_colour(angle));
    }
  }
  return can;
}

// The can seen from the camera 0.9 m away at truth: 800 points of the near half of its side.
ColoredCloud seen_can(const Pose& truth) {
  ColoredCloud scene;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> turn(0.f, 2.f * std::numbers::pi_v<float>);
  std::uniform_real_distribution<float> height(-0.5f * kCanHeight, 0.5f * kCanHeight);
  while (scene.size() < 800) {
    const float angle = turn(rng);
    const Eigen::Vector3f local = on_can(angle, height(rng));
    const Eigen::Vector3f p = truth.isometry() * local;
    const Eigen::Vector3f normal = truth.rotation * Eigen::Vector3f(local.x(), local.y(), 0.f);
    if (normal.dot(p) < 0.f) scene.push_back(p, stripe_colour(angle));  // facing the camera at the origin
  }
  return scene;
}

// The striped can, its axis tilted 60 degrees towards the camera, and its view with the points' colour features.
struct SeenStripedCan {
  ColoredCloud model = striped_can_model();
  std::vector<SmrFeature> model_features = compute_smr(model.colors);
  Pose truth = test::make_pose(Eigen::Vector3f(0.02f, 0.f, 0.9f), Eigen::Vector3f::UnitX(), test::radians(-60.f));
  ColoredCloud scene = seen_can(truth);
  std::vector<SmrFeature> scene_features = compute_smr(scene.colors);

  // The truth turned by `degrees` about the can's own axis.
  Pose lagging(float degrees) const {
    Pose p = truth;
    p.rotation =
        (truth.rotation * Eigen::Quaternionf(Eigen::AngleAxisf(test::radians(degrees), Eigen::Vector3f::UnitZ())))
            .normalized();
    return p;
  }
};

TEST(IcpRefinement, ColourPairsSeeATurnAboutTheSymmetryAxisThatGeometryCannot) {
  const SeenStripedCan can;
  const auto& [model, model_features, truth, scene, scene_features] = can;
  // The filter's estimate lags the can's turn about its own axis by 8 degrees (5.6 mm of arc).
  const Pose start = can.lagging(8.f);
  IcpRefinementOptions options = iterations(10);
  IcpRefinement geometric(options);
  const IcpResult shape_only = geometric.refine(scene.positions, model.positions, start);
  options.color_weight = 1.f;
  IcpRefinement colored(options);
  const IcpResult with_colour = colored.refine(scene.positions, scene_features, model.positions, model_features, start);
  const float shape_error = test::degrees(test::rotation_error(shape_only.pose, truth));
  const float colour_error = test::degrees(test::rotation_error(with_colour.pose, truth));
  std::printf("turned 8 deg about the axis: geometry %.2f deg, colour and geometry %.2f deg (%.2f mm)\n", shape_error,
              colour_error, 1e3f * test::translation_error(with_colour.pose, truth));
  // The shape cannot show the turn: the nearest points leave it.
  EXPECT_GT(shape_error, 6.f);
  ASSERT_TRUE(with_colour.refined);
  // Only the points near a stripe's edge pull (a point inside a stripe pairs with its nearest point of that colour),
  // so each iteration takes a share of the lag: 1.8 degrees left after 10.
  EXPECT_LT(colour_error, 2.5f);
  EXPECT_LT(test::translation_error(with_colour.pose, truth), 0.0015f);
  // Without the scene's features (or with color_weight 0) it is the geometric refinement, pose for pose.
  const IcpResult no_features = colored.refine(scene.positions, {}, model.positions, model_features, start);
  EXPECT_EQ(no_features.pose.rotation.coeffs(), shape_only.pose.rotation.coeffs());
  // The colour charge tells the turned pose from the truth; the shape's does not.
  const auto charge = [&](IcpRefinement& icp, std::span<const SmrFeature> features, const Pose& pose) {
    return icp.unexplained(scene.positions, features, model.positions, model_features, pose, 2000);
  };
  std::printf("charge turned / true: colour %.3f / %.3f, geometry %.3f / %.3f\n",
              charge(colored, scene_features, start), charge(colored, scene_features, truth),
              charge(geometric, {}, start), charge(geometric, {}, truth));
  EXPECT_GT(charge(colored, scene_features, start), 1.5f * charge(colored, scene_features, truth));
  EXPECT_NEAR(charge(geometric, {}, start), charge(geometric, {}, truth), 0.02f);
  // A feature span of another size than its points is refused.
  EXPECT_THROW(colored.refine(scene.positions, model_features, model.positions, model_features, start),
               std::invalid_argument);
}

// The pairing looks only at the model points that can cost less than the nearest one: its least costs are those of
// a search over every model point, at every lag of the turn (exact, not approximate).
TEST(IcpRefinement, ColourPairingIsTheLeastCostOverEveryModelPoint) {
  const SeenStripedCan can;
  const auto& [model, model_features, truth, scene, scene_features] = can;
  IcpRefinementOptions options = iterations(10);
  options.color_weight = 1.f;
  IcpRefinement colored(options);
  const float r = options.max_distance;
  for (const float lag : {0.f, 2.f, 5.f, 8.f, 12.f}) {
    const Pose pose = can.lagging(lag);
    const Eigen::Isometry3f to_object = pose.isometry().inverse();
    double sum = 0.0;
    for (std::size_t i = 0; i < scene.size(); ++i) {
      const Eigen::Vector3f local = to_object * scene.positions[i];
      const auto h = scene_features[i].dense();
      float least = -1.f;
      for (std::size_t j = 0; j < model.size(); ++j) {
        const float d2 = (model.positions[j] - local).squaredNorm();
        if (d2 > r * r) continue;
        const auto m = model_features[j].dense();
        float dc = 0.f;
        for (int k = 0; k < kSmrBins; ++k) dc += 0.5f * (h[k] - m[k]) * (h[k] - m[k]);
        const float cost = d2 + r * r * dc;
        if (least < 0.f || cost < least) least = cost;
      }
      sum += least < 0.f ? 1.0 : std::min(least / (r * r), 1.f);
    }
    const auto every_point = static_cast<int>(scene.size());
    EXPECT_NEAR(
        colored.unexplained(scene.positions, scene_features, model.positions, model_features, pose, every_point),
        sum / static_cast<double>(scene.size()), 1e-5)
        << "lag " << lag << " deg";
  }
}

TEST(IcpRefinement, InvalidOptionsThrow) {
  const auto bad = [](auto mutate) {
    IcpRefinementOptions o;
    mutate(o);
    EXPECT_THROW(IcpRefinement{o}, std::invalid_argument);
  };
  bad([](IcpRefinementOptions& o) { o.iterations = -1; });
  bad([](IcpRefinementOptions& o) { o.iterations = 51; });
  bad([](IcpRefinementOptions& o) { o.max_distance = 0.f; });
  bad([](IcpRefinementOptions& o) { o.min_paired_share = 1.5f; });
  bad([](IcpRefinementOptions& o) { o.max_translation = -0.1f; });
  bad([](IcpRefinementOptions& o) { o.max_rotation = 4.f; });
  bad([](IcpRefinementOptions& o) { o.max_points = 2; });
  bad([](IcpRefinementOptions& o) { o.anchor_weight = 0.9f; });
  bad([](IcpRefinementOptions& o) { o.anchor_weight = 1001.f; });
  bad([](IcpRefinementOptions& o) { o.color_weight = -0.1f; });
  bad([](IcpRefinementOptions& o) { o.color_weight = 10.5f; });
  IcpRefinementOptions too_far;
  too_far.max_distance = 0.5f;
  test::expect_invalid_argument([&] { too_far.validate("tracker"); }, "tracker.max_distance");
}

}  // namespace
}  // namespace mfot
