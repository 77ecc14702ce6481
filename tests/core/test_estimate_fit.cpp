#include <gtest/gtest.h>

#include <array>
#include <stdexcept>

#include "mfot/estimate_fit.hpp"
#include "mfot/hypothesis.hpp"
#include "synthetic_object.hpp"

namespace mfot {
namespace {

// The test box (10 x 15 x 8 cm, six face colours, textured halves) 1 m in front of the camera; the
// scene is its other sampling (no point shared with the model), seen from the camera: the half
// facing it (z < centre), as a depth camera sees a box.
struct SeenBox {
  ObjectModel model = test::make_model(test::make_test_object(0.f, 0.008f, true));
  Pose truth = test::make_pose(Eigen::Vector3f(0.f, 0.f, 1.f), Eigen::Vector3f(1.f, 1.f, 0.f), 0.5f);
  Eigen::AlignedBox3f box = model_bounding_box(model);

  HypothesisData seen() const {
    const ColoredCloud all = test::transformed(test::make_test_object(0.5f, 0.008f, true), truth);
    ColoredCloud front;
    for (std::size_t k = 0; k < all.size(); ++k) {
      if (all.positions[k].z() < truth.translation.z()) front.push_back(all.positions[k], all.colors[k]);
    }
    return test::make_hypothesis(front);
  }
  Pose turned(const Eigen::Vector3f& axis, float degrees) const {
    Pose p = truth;
    p.rotation = (Eigen::Quaternionf(Eigen::AngleAxisf(test::radians(degrees), axis.normalized())) * truth.rotation)
                     .normalized();
    return p;
  }
};

const std::array<Eigen::Vector3f, 3> kAxes{Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitY(),
                                           Eigen::Vector3f::UnitZ()};

TEST(EstimateFit, ARightEstimateFitsAndTurnedOnesFitLessTheMoreTheyAreTurned) {
  const SeenBox box;
  const HypothesisData data = box.seen();
  EstimateFit fit;
  const float right = fit.fit(data, box.model, box.box, box.truth);
  EXPECT_GT(right, 0.85f);
  EXPECT_EQ(fit.claimed_points(), data.points.size());  // all of it lies on the model's surface
  float previous = right;
  for (const float degrees : {10.f, 20.f, 40.f}) {
    for (const Eigen::Vector3f& axis : kAxes) {
      const float turned = fit.fit(data, box.model, box.box, box.turned(axis, degrees));
      EXPECT_LT(turned, right - 0.1f) << degrees << " deg about " << axis.transpose();
    }
    const float about_x = fit.fit(data, box.model, box.box, box.turned(Eigen::Vector3f::UnitX(), degrees));
    EXPECT_LT(about_x, previous) << degrees;
    previous = about_x;
  }
}

TEST(EstimateFit, ASameOutlineTurnedOntoOtherFacesFailsOnColour) {
  // Turned half a turn about the box's own axis: the same outline, the opposite faces' colours.
  const SeenBox box;
  const HypothesisData data = box.seen();
  Pose flipped = box.truth;
  flipped.rotation =
      (box.truth.rotation * Eigen::Quaternionf(Eigen::AngleAxisf(test::radians(180.f), Eigen::Vector3f::UnitZ())))
          .normalized();
  EstimateFit fit;
  const float right = fit.fit(data, box.model, box.box, box.truth);
  const float wrong = fit.fit(data, box.model, box.box, flipped);
  EXPECT_EQ(fit.claimed_points(), data.points.size());  // geometry alone cannot tell
  EXPECT_LT(wrong, 0.5f * right);
}

TEST(EstimateFit, PointsOutsideTheClaimDoNotCountAndTooFewClaimedGiveZero) {
  const SeenBox box;
  HypothesisData data = box.seen();
  EstimateFit fit;
  const float alone = fit.fit(data, box.model, box.box, box.truth);
  // A hand 5 cm in front of the box (beyond the claim margin) changes nothing.
  const HypothesisData hand = test::make_hypothesis(
      test::transformed(test::make_colored_box(Eigen::Vector3f(0.08f, 0.08f, 0.02f), 0.008f, test::kSixColours),
                        test::make_pose(Eigen::Vector3f(0.f, 0.f, 0.88f), Eigen::Vector3f::UnitZ(), 0.f)));
  data.points.insert(data.points.end(), hand.points.begin(), hand.points.end());
  data.features.insert(data.features.end(), hand.features.begin(), hand.features.end());
  EXPECT_FLOAT_EQ(fit.fit(data, box.model, box.box, box.truth), alone);

  EstimateFitOptions strict;
  strict.min_claimed_points = static_cast<int>(box.seen().points.size()) + 1;
  EstimateFit needs_more(strict);
  EXPECT_EQ(needs_more.fit(box.seen(), box.model, box.box, box.truth), 0.f);
  EXPECT_EQ(fit.fit(HypothesisData{}, box.model, box.box, box.truth), 0.f);
}

TEST(EstimateFit, RejectsBadInputAndOptions) {
  const SeenBox box;
  HypothesisData data = box.seen();
  data.features.pop_back();
  EstimateFit fit;
  EXPECT_THROW(fit.fit(data, box.model, box.box, box.truth), std::invalid_argument);
  EstimateFitOptions o;
  o.match_distance = 0.f;
  EXPECT_THROW(EstimateFit{o}, std::invalid_argument);
  o = {};
  o.claim_margin = -0.01f;
  EXPECT_THROW(EstimateFit{o}, std::invalid_argument);
  o = {};
  o.min_claimed_points = 0;
  EXPECT_THROW(EstimateFit{o}, std::invalid_argument);
}

}  // namespace
}  // namespace mfot
