#pragma once
// Refinement of a pose estimate on the model: point-to-point ICP (Besl and McKay 1992) of the scored
// scene points onto the object's model, each iteration's rigid fit in closed form (the SVD of the
// cross-covariance, Arun et al. 1987 / Umeyama 1991). A departure from the thesis, which takes the
// particles' weighted mean: the JCSD score is smooth over its 15 mm kernel, so on an object turning
// fast its mode lies several degrees from the true pose at some views whatever the particle count
// (2000 particles on the H100 still leave 2-3 degrees of it), while the model's surface pins it within
// the voxel size. With color_weight the pairs are chosen in colour and space (coloured ICP), so a turn that the
// texture shows but the shape does not (a labelled can about its axis) is kept, not pulled back by the geometry.
// TrackingStep runs it on every stepped frame, on the points left after the occluders
// and the points other objects claim are removed (a finger gripping the object would otherwise pair
// with the face beneath it), and holds the filter where too few are left (hold_min_scored_share).

#include <array>
#include <cstddef>
#include <span>
#include <string>
#include <vector>

#include "mfot/smr_feature.hpp"
#include "mfot/spatial_hash.hpp"
#include "mfot/types.hpp"

namespace mfot {

// Member defaults: for library users and unit tests; the services fill every field from
// configs/default.yaml (tracker.icp_*) and the method's constants (docs/method.md).
struct IcpRefinementOptions {
  int iterations = 0;          // [0, 50]; 0 = off (the estimate stays)
  float max_distance = 0.01f;  // a scene point pairs with the nearest model point this close, metres (0, 0.1]
  // With fewer of the scene points paired than this share, the estimate stays: too little of the
  // object is seen, or the estimate is too far off for local pairs. [0, 1]
  float min_paired_share = 0.5f;
  // A refinement that moves the estimate further than this in all is refused (the estimate stays): a
  // correction this large is not a local one. Metres [0, 1] and radians [0, pi].
  float max_translation = 0.02f;
  float max_rotation = 0.175f;
  // At most this many scene points take part, an even stride over them (the nearest-point queries are
  // the cost; too few leave the fit's noise, and a weakly held direction such as a hand's roll about its
  // forearm, which shows only in its palm, rests on a handful of them). [3, 1000000]
  int max_points = 400;
  // The pairs of the object's first-view points (see refine's step 1) weigh this much in the fit, the
  // points grown since 1: where the first view shows, it holds the object's frame, which the pose error
  // of each growth would otherwise shift (docs/experiment-log.md "Anchored on the first view"). [1, 1000]; 1 = all
  // alike.
  float anchor_weight = 1.f;
  // Colour in the pairing (coloured ICP, in the spirit of Park et al. 2017 and PCL's GICP6D): where both the scene
  // and the model give their points' SMR features, a scene point pairs, among the model points within max_distance,
  // with the one of least |scene - model|^2 + (color_weight max_distance)^2 d_c, d_c = half the squared difference of
  // the two SMR vectors, in [0, 1] (0: one colour, 1: no bin shared). With 1, a point of the scene point's colour
  // anywhere within reach ranks before one of a wholly other colour at the same place. [0, 10]; 0 = geometry alone.
  float color_weight = 0.f;
  // Throws std::invalid_argument naming the field as owner.field.
  void validate(const std::string& owner = "IcpRefinementOptions") const;
};

struct IcpResult {
  Pose pose;  // refined, or the start pose when not refined
  bool refined = false;
  std::size_t paired = 0;   // sampled scene points paired in the last iteration run
  std::size_t sampled = 0;  // scene points taking part in the last iteration run (at most max_points)
};

// Steps of refine():
//  1. build a spatial hash over the model's points (object frame), unless they are the last call's; with
//     anchor_weight > 1, mark the model's anchors: the points it shares (exactly: growth and thinning move
//     no point) with the first model this refinement was given: the object's first view, which placed its
//     frame exactly, whereas each point grown since was placed with the pose estimate of its frame, errors
//     included. A model sharing none of them (rebuilt in a new frame) is the new first view;
//  2. each iteration: map the scene points (an even sample of at most max_points) into the object frame with the
//     inverse of the current
//     pose, pair each with the nearest model point within max_distance (after the first iteration, a point
//     whose last pair provably stays the nearest over the pose's move keeps it without a query), or, with
//     colours (color_weight > 0), with the one of least colour-and-space cost within max_distance: only the model
//     points nearer than the nearest one's cost are looked at, none where the nearest point's bound proves it the
//     least (inside a patch of one colour); with fewer than
//     min_paired_share of them paired, stop and keep the start pose;
//  3. the rigid transform that best maps the paired model points onto their scene points (weighted least
//     squares, closed form; an anchor's pair weighs anchor_weight, the others 1) is the new pose; when
//     every point of the sample paired as in the last iteration, that is the pose already (converged):
//     the iterations end;
//  4. after the iterations, refuse a pose further from the start than max_translation /
//     max_rotation.
// Deterministic, no random draws. Non-copyable: it owns the model hash (kept while the model's points
// stay the same), the first view and the pair buffers.
class IcpRefinement {
 public:
  explicit IcpRefinement(const IcpRefinementOptions& options = {});
  IcpRefinement(const IcpRefinement&) = delete;
  IcpRefinement& operator=(const IcpRefinement&) = delete;

  const IcpRefinementOptions& options() const { return options_; }

  // scene: camera frame; model: object frame; start: object -> camera. Geometry alone.
  IcpResult refine(std::span<const Eigen::Vector3f> scene, std::span<const Eigen::Vector3f> model, const Pose& start);
  // The same with the points' colour features (one per point, or empty: geometry alone), paired in colour and
  // space when color_weight > 0. Throws std::invalid_argument when a non-empty span's size differs from its points'.
  IcpResult refine(std::span<const Eigen::Vector3f> scene, std::span<const SmrFeature> scene_features,
                   std::span<const Eigen::Vector3f> model, std::span<const SmrFeature> model_features,
                   const Pose& start);
  // How much of scene (camera frame) the model (object frame) at pose leaves unexplained, in [0, 1]: the mean,
  // over an even sample of at most max_points (>= 3) scene points, of the squared distance to the nearest model
  // point over max_distance squared (a point with none within max_distance counts 1); 1 for an empty scene or
  // model. Uses (and keeps) refine()'s model hash.
  float unexplained(std::span<const Eigen::Vector3f> scene, std::span<const Eigen::Vector3f> model, const Pose& pose,
                    int max_points);
  // The same with colour features (as refine's): with color_weight > 0 a point counts its least pairing cost over the
  // model points within max_distance, over max_distance squared, at most 1.
  float unexplained(std::span<const Eigen::Vector3f> scene, std::span<const SmrFeature> scene_features,
                    std::span<const Eigen::Vector3f> model, std::span<const SmrFeature> model_features,
                    const Pose& pose, int max_points);

 private:
  IcpRefinementOptions options_;
  SpatialHash model_hash_;
  std::vector<Eigen::Vector3f> hashed_model_;  // the points model_hash_ was built on
  // Step 1's hash (and anchors) for model, rebuilt only when its points differ from the last ones.
  void use_model(std::span<const Eigen::Vector3f> model);
  // Checks the feature spans' sizes and sets colored_ (both given and color_weight > 0) and model_features_.
  void use_colors(std::span<const Eigen::Vector3f> scene, std::span<const SmrFeature> scene_features,
                  std::span<const Eigen::Vector3f> model, std::span<const SmrFeature> model_features);
  // An even sample of scene (at most max_points) into sample_, with its points' dense colours when colored_.
  void sample(std::span<const Eigen::Vector3f> scene, std::span<const SmrFeature> scene_features, int max_points);
  // Runs up to iterations on the sample (steps 2-3), moving pose; false when too few of it paired.
  bool iterate(std::span<const Eigen::Vector3f> sample, std::span<const Eigen::Vector3f> model, Eigen::Isometry3f& pose,
               IcpResult& result);

  std::vector<Eigen::Vector3f> sample_;         // the scene points of the iterations running
  bool colored_ = false;                        // this call pairs in colour and space (use_colors)
  std::span<const SmrFeature> model_features_;  // the call's model features, when colored_
  // A sample point's dense SMR vector and its squared norm, when colored_.
  struct SampleColor {
    std::array<float, kSmrBins> bins{};
    float squared_norm = 0.f;
  };
  std::vector<SampleColor> sample_colors_;
  std::vector<int> candidates_;        // pair_colored's radius search
  std::vector<int> nearest_;           // each sample point's model point (-1: none) in this iteration
  std::vector<int> previous_nearest_;  // ... and in the last
  // A sample point's last query in the object frame, its nearest model point's distance and a lower bound
  // on the others' (SpatialHash::nearest_with_bound), metres. Later iterations move the pose by a fraction
  // of the point spacing, so most points keep their nearest provably and skip the query (same pairs).
  struct PairBound {
    Eigen::Vector3f query = Eigen::Vector3f::Zero();
    float distance = 0.f;
    float others = 0.f;
    int nearest = -1;  // the nearest model point by position (pair_colored's; -1: none or not yet queried)
  };
  std::vector<PairBound> bounds_;  // per sample point
  // The nearest model point within max_distance of local (-1: none), as SpatialHash::nearest would give:
  // last_nearest when bound proves it still is, otherwise by a new query that renews bound.
  int pair(const Eigen::Vector3f& local, std::span<const Eigen::Vector3f> model, int last_nearest,
           PairBound& bound) const;
  // The model point of least colour-and-space cost within max_distance of local (-1: none), whose colour is color;
  // cost gets that cost, square metres. With use_last, bound (as pair's, for the nearest point by position) is the
  // sample point's from the last iteration.
  int pair_colored(const Eigen::Vector3f& local, const SampleColor& color, std::span<const Eigen::Vector3f> model,
                   bool use_last, PairBound& bound, float& cost);
  // Step 1's anchors: the first view, indexed (empty: none yet); each model point's weight (empty: all alike).
  void weigh_anchors();
  SpatialHash first_view_hash_;
  std::vector<float> weights_;
  std::vector<Eigen::Vector3f> paired_model_;
  std::vector<Eigen::Vector3f> paired_scene_;
  std::vector<float> paired_weights_;
};

}  // namespace mfot
