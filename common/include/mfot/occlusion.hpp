#pragma once
// Ray-casting occlusion test of a model against the scene (thesis 4.1's test for the fitting
// distance, after [RC11]); mfot also uses it while tracking to tell a hidden object from a lost one.

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "mfot/likelihood.hpp"
#include "mfot/spatial_hash.hpp"
#include "mfot/types.hpp"

namespace mfot {

struct OcclusionOptions {
  // Half-angle of the viewing cone around a model point's camera ray, as a tangent (distance in
  // the normalised image plane x/z, y/z), (0, 0.1]. 0.006 is ~3.4 px at fx = 570, a little more
  // than the angular spacing of 5 mm voxels at 1 m, so a surface in front always has a point
  // inside the cone.
  float window = 0.006f;
  // A scene point occludes only when it is at least this much closer to the camera (metres,
  // [0, 1]): the points of the object's own visible surface never count.
  float depth_margin = 0.010f;
  // occluded_share only: a scene point this close to one of the model's own points (metres,
  // [0, 0.1]) is the object's own surface, never an occluder (a turned object's far side lies
  // behind its near side). 0: every scene point can occlude.
  float own_surface_radius = 0.010f;
  void validate() const;
};

// The camera's field of view in normalised image coordinates (x/z, y/z): the image's pixel edges.
struct ViewBounds {
  float x_min = 0.f;
  float x_max = 0.f;
  float y_min = 0.f;
  float y_max = 0.f;
  // Pixels [0, width) x [0, height) of an image with these intrinsics (fx, fy > 0).
  static ViewBounds of_image(int width, int height, float fx, float fy, float cx, float cy);
  bool contains(float x_over_z, float y_over_z) const {
    return x_over_z >= x_min && x_over_z <= x_max && y_over_z >= y_min && y_over_z <= y_max;
  }
};

// Occlusion of model points by the scene, the camera at the origin looking along +z. A point m
// is occluded when a scene point lies inside the cone of half-angle `window` around the ray
// through m and is at least depth_margin closer to the camera (depth along z); a point at
// z <= 0 is behind the camera and counts as occluded. Steps: set_scene indexes the scene's
// normalised image coordinates (x/z, y/z) with their depth, set_model places the model (and
// indexes its own surface); every query is one cone search.
class OcclusionTest {
 public:
  explicit OcclusionTest(const OcclusionOptions& options = {});
  OcclusionTest(const OcclusionTest&) = delete;
  OcclusionTest& operator=(const OcclusionTest&) = delete;

  const OcclusionOptions& options() const { return options_; }

  void set_scene(std::span<const Eigen::Vector3f> scene_points);  // camera frame
  // The image the scene came from (nullopt: unknown, every ray counts as in view): a model point outside
  // it is never seen through, since the camera cannot see past where it does not look.
  void set_view(const std::optional<ViewBounds>& view) { view_ = view; }
  bool occluded(const Eigen::Vector3f& point) const;  // camera frame; safe to call from several threads
  // The model (object frame) moved by pose (object -> camera) for the two questions below; an
  // object's tracking step sets it once and asks both.
  void set_model(std::span<const Eigen::Vector3f> model_points, const Pose& pose);
  // Share of the set model's points occluded by scene points other than the object's own surface
  // (own_surface_radius), in [0, 1]; 0 for an empty model.
  float occluded_share();
  float occluded_share(std::span<const Eigen::Vector3f> model_points, const Pose& pose);  // set_model + the above
  // Share of the set model's points in front of the camera and inside the view (set_view) with no
  // scene point on their viewing cone nearer than depth_margin behind them: the view sees past where
  // the model would be (to what lies behind, or to nothing: a table that preprocessing removed), so
  // the object is not there. In [0, 1] of all its points; 0 for an empty model. A model point's own
  // near side covers its far side.
  float seen_through_share();
  // The same share of an even stride of at most max_points (>= 1) of model_points (object frame) moved by
  // pose, without set_model (nothing indexed, the set model kept): a cheap comparison of poses.
  float seen_through_share(std::span<const Eigen::Vector3f> model_points, const Pose& pose, int max_points) const;
  // The inverse question, asked of hypothesis data: removes from data the points that occlude the
  // set model — points at least depth_margin in front of a model point on their viewing cone and
  // farther than own_surface_radius from every model point (a hand in front of the object, not
  // its own near side). The remaining points keep their order. Returns how many were removed.
  // Independent of set_scene().
  std::size_t remove_occluders(HypothesisData& data);

 private:
  // A cone index: (x/z, y/z, 0) of the points with z > 0 in hash, each with its point in sources.
  static void index_rays(std::span<const Eigen::Vector3f> points, std::vector<Eigen::Vector3f>& rays,
                         std::vector<Eigen::Vector3f>& sources, SpatialHash& hash);
  // Whether the view sees past point (camera frame, in front of the camera and inside the view).
  bool seen_through(const Eigen::Vector3f& point) const;
  // Whether a scene point at least depth_margin in front of point (camera frame) lies on its viewing cone
  // and is_occluder(its index in ray_scene_) says it counts; a point at z <= 0 is occluded.
  template <class IsOccluder>
  bool occluded_by(const Eigen::Vector3f& point, IsOccluder&& is_occluder) const;

  OcclusionOptions options_;
  std::optional<ViewBounds> view_;
  SpatialHash ray_hash_;  // (x/z, y/z, 0) of scene points with z > 0
  std::vector<Eigen::Vector3f> ray_points_;
  std::vector<Eigen::Vector3f> ray_scene_;   // the scene point of each ray point (its depth is z)
  SpatialHash own_hash_;                     // own_points_, when own_surface_radius > 0
  std::vector<Eigen::Vector3f> own_points_;  // the set model in the camera frame
  // occluded_share: per scene ray point, whether it lies within own_surface_radius of the set model.
  enum OwnSurface : std::uint8_t { kUnknown, kYes, kNo };
  std::vector<OwnSurface> scene_on_own_surface_;
  bool model_rays_indexed_ = false;  // remove_occluders indexes the model's rays once per set_model
  SpatialHash model_ray_hash_;       // (x/z, y/z, 0) of the model's points with z > 0
  std::vector<Eigen::Vector3f> model_rays_;
  std::vector<Eigen::Vector3f> model_ray_points_;  // the model point of each ray (its depth is z)
};

}  // namespace mfot
