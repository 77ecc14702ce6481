#pragma once
// One object's tracking step on one frame: hypothesis data (thesis 3.3) and the particle filter
// (2.2.2, 3.1, likelihood 3.20/3.21), with mfot's occlusion handling around them (docs/experiment-log.md "Where
// mfot departs from the thesis"): the thesis scores every scene point near the last estimate, so a
// hand passing over an object pulls its filter onto the hand.

#include <cstddef>
#include <optional>
#include <span>
#include <vector>

#include "mfot/estimate_fit.hpp"
#include "mfot/hypothesis.hpp"
#include "mfot/icp_refinement.hpp"
#include "mfot/likelihood.hpp"
#include "mfot/occlusion.hpp"
#include "mfot/particle_filter.hpp"
#include "mfot/smr_feature.hpp"
#include "mfot/spatial_hash.hpp"

namespace mfot {

// Member defaults: the thesis's values, for library users and unit tests; the services and
// mfot-inprocess fill every field from configs/default.yaml and the method's constants (docs/method.md).
struct TrackingStepOptions {
  HypothesisOptions hypothesis;
  // Colour feature of the scored points (the models' features must use the same options).
  SmrOptions smr;
  // Cone, depth margin and own-surface radius of the occlusion tests below.
  OcclusionOptions occlusion;
  // The occlusion handling (departure from the thesis): a frame in which at least this share of the model, at the
  // last estimate, is occluded by nearer scene points holds the filter (ParticleFilter::hold) instead of stepping it:
  // the data cannot show a hidden object; and in every stepped frame, the hypothesis points in front of the model at
  // the last estimate (the hand over it) are left out of the likelihood (OcclusionTest::remove_occluders). [0, 1];
  // 0 = always step on every point (thesis).
  float hold_occluded_share = 0.f;
  // Holds last at most this many frames in a row [1, 100000] (90: 3 s at 30 fps; the shipped
  // tracker.max_hold_frames). A hold cannot tell a hidden object from one whose estimate slipped
  // behind a surface (an object put down on another a few cm from where it was held): past this, the
  // filter steps on every point in the margin, as in the thesis, until the share drops below
  // hold_occluded_share again.
  int max_hold_frames = 90;
  // A frame in which, after the occluders and the claimed points are left out, fewer scene points
  // remain to score than this share of the model's points holds the filter too (departure from the
  // thesis): a hand covering a gripped box leaves a strip of its edge, on which the filter and its
  // refinement slide off the object. Counts towards max_hold_frames; past it the filter steps on
  // what is left. [0, 1]; 0 = always step on what is left.
  float hold_min_scored_share = 0.f;
  // How the confidence of a stepped estimate is measured (EstimateFit).
  EstimateFitOptions fit;
  // The published confidence is the fit times (1 - this weight times the share of the model the view sees
  // through at the estimate, OcclusionTest::seen_through_share), at least 0 (departure: the fit judges only
  // the points the estimate claims, and a turned or shifted estimate still claims points on the object; the
  // parts of its model it turns into free space, where the camera sees past them, tell it is wrong). [0, 100];
  // 0 = the fit alone; > 0 needs hold_occluded_share > 0 (the scene's rays are indexed there).
  float confidence_seen_through_weight = 0.f;
  // A held frame's confidence is the last stepped frame's halved every this many holds in a row:
  // a hidden object may be moving (carried behind the hand). Frames, [1, 100000].
  float hold_confidence_half_life = 15.f;
  // Points claimed by other objects (departure from the thesis): a hypothesis point within this
  // distance of another tracked object's model at its last pose, and nearer to it than to this
  // object's model at its last estimate, is left out of the likelihood (the fingers gripping a box
  // lie within a centimetre of its faces and pull its estimate onto the hand). Metres [0, 0.1];
  // 0 = score them (thesis). Needs set_claimed_points().
  float exclude_claimed_radius = 0.f;
  // How far beyond the model's box the other objects' points matter (ObjectManager::claimed_points):
  // the hypothesis margin plus the claim radius; 0 when the claim radius is 0.
  float claimed_margin() const {
    return exclude_claimed_radius > 0.f ? hypothesis.margin + exclude_claimed_radius : 0.f;
  }
  // How hard the filter follows the motion of an isolated object (departure from the thesis): in a
  // frame where no other tracked object's model lies within claimed_margin() of this object's box
  // (set_claimed_points gave none), the filter steps with these settings instead of its options'.
  // Without a hand or a neighbour near it, the score's mode is the object, and following it harder
  // (more particles moved by dX, a pattern search on the score) keeps up with fast turns; where a hand
  // grips the object the mode lies partly on the hand, and the thesis's broad step holds it better
  // (docs/experiment-log.md "Motion-model options"). Only with exclude_claimed_radius > 0 (else no object is known to
  // be isolated: the filter's own step everywhere, the thesis).
  StepMotion isolated_motion{.predicted_fraction = 0.75f, .refine_rounds = 2};
  // Every stepped frame's estimate refined on the model's surface (IcpRefinement on the points left
  // after the occluders and the claimed points are removed; iterations 0 = off, the thesis's weighted
  // mean); its dX then comes from the refined pose, and the particle set moves with it as far as the
  // filter's follow_replaced_estimate says. Departure from the thesis: the JCSD score is smooth over
  // its 15 mm kernel, so its mode lies degrees from the pose at some views.
  IcpRefinementOptions icp;
  // The last estimate as a second start (departure from the thesis; docs/experiment-log.md "A partly hidden object kept
  // where it was"). The JCSD score sums the model's density at the scene points, so where part of an object is hidden,
  // a pose that sinks its visible surface into the model's hidden side scores higher. In a frame where at least this
  // share of the model is occluded at the last estimate and no touching object's motion is set (a pushed or gripped
  // object moves), the last estimate is refined too (icp's settings, on at most last_pose_check_points scored points),
  // and it replaces the filter's estimate when it explains the view better: its share of scored points unexplained
  // (IcpRefinement::unexplained) plus its share of model points seen through (OcclusionTest::seen_through_share: where
  // the view shows what lies behind), each on at most last_pose_check_points points, is lower than the estimate's. [0,
  // 1]; 0 = off (the thesis; step 5d too); > 0 needs hold_occluded_share > 0 (the occluded share is measured there).
  float last_pose_check_occluded_share = 0.f;
  int last_pose_check_points = 400;  // [3, 1000000]
  // The companion's pose as a second start (step 5d; departure from the thesis; docs/experiment-log.md "A gripped
  // object started where its companion takes it"), with the last pose check: in a frame where a touching object's
  // motion is set (set_companion_motion) and at least last_pose_check_occluded_share (> 0) of the model is occluded,
  // the last estimate moved by that motion is refined too, and it replaces the filter's estimate when its charge (as
  // the last pose check's, on last_pose_check_points) is lower: a box turned by the hand that grips it shows too little
  // of itself for the refinement to leave where it was, and a still box under a hand hovering over it keeps its place.
  // The filter's turn, kept where the companion turns the same way and the refinement turns it back (step 5e; departure
  // from the thesis; docs/experiment-log.md "A turn the filter and the companion agree on"). On the preprocessor's
  // fixed voxel grid a surface at rest gives the same voxel means frame after frame, so a box that a hand turns quickly
  // from rest pairs point to point with where it was, and ICP turns the filter's estimate back by about as much as the
  // filter's step turned it. In a frame where a companion's motion is set and turns at least companion_turn_min (a hand
  // that pushes an object mostly slides it), the filter's step turned the estimate at least as much from the last
  // estimate, about an axis within acos(companion_turn_min_cosine) of the companion's turn, and the refined estimate
  // (after steps 5b-5d) kept less than companion_turn_max_kept of that turn along it: the estimate takes the filter's
  // rotation (about the object's origin) and keeps the refined translation: two independent measurements agree on the
  // turn, the box's own score and the hand's motion (the hand's motion alone, taken as the box's, is much worse:
  // docs/departures.md). Radians [0, pi] (0 = off, the thesis), [-1, 1] and [0, 1].
  float companion_turn_min = 0.f;
  float companion_turn_min_cosine = 0.8f;
  float companion_turn_max_kept = 0.3f;
  // The constant-velocity prediction as a second start (step 5f; departure from the thesis). In a frame where steps
  // 5c-5d did not run and the prediction (the last estimate moved by the last dX, 2.13) lies at least
  // predicted_start_min_turn or predicted_start_min_shift from the refined estimate, the prediction is refined too
  // and replaces the estimate when its charge (the last pose check's, on last_pose_check_points) is lower. The
  // filter's 100 particles spread about a turn's prediction lag an object that turns several degrees a frame (a
  // striped bottle spun about its axis slips a stripe), and ICP from a lagging estimate pairs each stripe with its
  // neighbour; from the prediction it pairs it with itself. Radians [0, pi] and metres [0, 1]; both 0 = off (the
  // thesis); > 0 needs hold_occluded_share > 0 (the charge's seen-through share).
  float predicted_start_min_turn = 0.f;
  float predicted_start_min_shift = 0.f;
  void validate() const;  // throws std::invalid_argument naming the field
};

struct TrackingStepResult {
  Pose estimate;
  bool held = false;                  // the object was hidden, or too little of it left to score: no step
  bool hold_expired = false;          // held for more than max_hold_frames: stepped (on every point when hidden)
  float occluded_share = 0.f;         // of the model at the last estimate (0 when not tested)
  std::size_t hypothesis_points = 0;  // scored points (after removing occluders)
  std::size_t occluders_removed = 0;
  std::size_t claimed_removed = 0;    // left out as claimed by other objects
  bool isolated = false;              // stepped with isolated_motion (no other object near)
  bool icp_refined = false;           // the estimate was refined on the model's surface (icp)
  bool companion = false;             // stepped with a companion's motion (set_companion_motion)
  bool last_pose_kept = false;        // the refined last estimate replaced the filter's (last_pose_check_*)
  bool companion_pose_kept = false;   // the refined companion's pose replaced the filter's (step 5d)
  bool companion_turn_kept = false;   // the filter's turn, agreeing with the companion's, was kept (companion_turn_min)
  bool predicted_start_kept = false;  // the refined constant-velocity prediction replaced the estimate (step 5f)
  // EstimateFit of the new estimate on the scored points, in [0, 1] (0 when held).
  float fit = 0.f;
  // Share of the model the view sees through at the new estimate, on an even sample of EstimateFit::kScoredPoints
  // of it (0 when held, or when confidence_seen_through_weight is 0: not measured).
  float seen_through_share = 0.f;
  // The fit lowered by the seen-through share (confidence_seen_through_weight), in [0, 1]; a held
  // frame's is the last stepped frame's, decaying with hold_confidence_half_life; 0 before the first step.
  float confidence = 0.f;
};

// Steps of track():
//  1. when hold_occluded_share > 0: the model's occluded share at the last estimate; at or above
//     it the filter holds and the step ends, unless it has held max_hold_frames in a row;
//  2. select the hypothesis data around the last estimate (3.3);
//  3. when hold_occluded_share > 0 (and the hold has not expired): remove the points in front of the
//     model at the last estimate;
//  3b. when exclude_claimed_radius > 0: remove the points that another object's model (the points
//     of set_claimed_points) lies within that radius of, and nearer than this model at the last
//     estimate;
//  3c. when hold_min_scored_share > 0 and fewer points are left than that share of the model's:
//     the filter holds and the step ends, unless it has held max_hold_frames in a row;
//  4. compute the SMR features (3.2.1) of the points left, only those: the rest of the scene is
//     never scored by this object;
//  5. step the filter with the likelihood on what is left (with isolated_motion when exclude_claimed_radius > 0
//     and no other object's model is near; with the companion's motion when one was set);
//  5b. when icp.iterations > 0: refine the estimate on the model's surface with the same points (in colour and
//      space with icp.color_weight > 0: the points' SMR features against the model's, here and in 5c-5d);
//  5c. when last_pose_check_occluded_share > 0, at least that share is occluded and no companion's motion is
//      set: refine the last estimate too, and keep it instead when it explains the view better;
//  5d. when last_pose_check_occluded_share > 0, a companion's motion is set and at least that share is
//      occluded: the same with the last estimate moved by the companion's motion (one block with 5c: a frame runs
//      one of the two, by whether a companion is set);
//  5e. when companion_turn_min > 0 and a companion's motion is set that turns at least that much: where the filter's
//      step turned the estimate at least as much, about an axis near the companion's turn, and the refined estimate
//      kept less than companion_turn_max_kept of that turn, the estimate takes the filter's rotation;
//  5f. when predicted_start_min_turn or predicted_start_min_shift > 0 and steps 5c-5d did not run: where the
//      constant-velocity prediction lies that far from the estimate, refine it too and keep it instead when it explains
//      the view better (as 5c);
//  6. measure the confidence of the new estimate: its fit on the same points (EstimateFit), lowered by the
//     share of its model the view sees through (confidence_seen_through_weight).
// One per object: it counts the object's holds. Deterministic: no random draws of its own (the
// filter owns its generator). Non-copyable: it owns the occlusion indexes and the hypothesis
// buffers, reused across frames.
class TrackingStep {
 public:
  explicit TrackingStep(const TrackingStepOptions& options = {});
  TrackingStep(const TrackingStep&) = delete;
  TrackingStep& operator=(const TrackingStep&) = delete;

  const TrackingStepOptions& options() const { return options_; }

  // model_box is model_bounding_box(model), kept by the caller since the model changes less often
  // than the scene.
  TrackingStepResult track(const ColoredCloud& scene, const ObjectModel& model, const Eigen::AlignedBox3f& model_box,
                           ParticleFilter& filter, Likelihood& likelihood);

  const HypothesisData& hypothesis() const { return hypothesis_; }  // of the last track()
  // The other tracked objects' model points at their last poses near this object (camera frame;
  // ObjectManager::claimed_points), for exclude_claimed_radius; kept until the next call.
  void set_claimed_points(std::span<const Eigen::Vector3f> points);
  // The motion a touching object's last step would give this object (ObjectManager's companion,
  // ManagedObject::companion_motion), for the filter's companion_fraction; nullopt = none. Kept until
  // the next call.
  void set_companion_motion(const std::optional<PoseVector>& motion) { companion_motion_ = motion; }
  // The image the scenes come from (nullopt: unknown): a model point outside it is never seen through
  // (OcclusionTest::set_view), in steps 5c and 5d and the confidence. Kept until the next call.
  void set_view(const std::optional<ViewBounds>& view) { occlusion_.set_view(view); }
  // Forgets the holds in a row (a new object, or its filter reset).
  void reset() {
    held_in_row_ = 0;
    last_confidence_ = 0.f;
  }

 private:
  // Holds the filter for this frame (steps 1 and 3c): no step, the confidence decays.
  void hold(ParticleFilter& filter, TrackingStepResult& result);
  // Removes the hypothesis points claimed by other objects (exclude_claimed_radius); returns how many.
  std::size_t remove_claimed(const ObjectModel& model, const Pose& last);

  TrackingStepOptions options_;
  OcclusionTest occlusion_;
  HypothesisData hypothesis_;
  EstimateFit fit_;
  IcpRefinement icp_;
  IcpRefinement
      last_pose_icp_;  // steps 5c, 5d and 5f: icp's settings on at most last_pose_check_points, its own model hash
  // Steps 5c, 5d and 5f: start refined (icp's settings on last_pose_check_points) when it explains the view better than
  // estimate, else nullopt.
  std::optional<Pose> better_start(const ObjectModel& model, const Pose& start, const Pose& estimate);
  // Step 5f: whether a and b lie at least predicted_start_min_shift or predicted_start_min_turn apart (each where > 0).
  bool lies_apart(const Pose& a, const Pose& b) const;
  // Step 5e: whether the companion and the filter's estimate (from last) both turned at least companion_turn_min, about
  // axes within acos(companion_turn_min_cosine), and the refined estimate kept less than companion_turn_max_kept of it.
  bool keeps_filter_turn(const Pose& last, const Pose& filtered, const Pose& refined,
                         const PoseVector& companion) const;
  SpatialHash claimed_hash_;  // set_claimed_points
  std::vector<Eigen::Vector3f> claimed_points_;
  std::optional<PoseVector> companion_motion_;
  SpatialHash own_;  // the model at the last estimate, for exclude_claimed_radius
  std::vector<Eigen::Vector3f> own_points_;
  int held_in_row_ = 0;
  float last_confidence_ = 0.f;
};

}  // namespace mfot
