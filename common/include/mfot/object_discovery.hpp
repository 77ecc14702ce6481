#pragma once
// Object discovery by convexity: where an object is born (the first frame, a cluster no tracked
// object explains), the cluster is split into the locally convex parts of its surface, so that
// touching and stacked objects are found apart from the first frame (thesis 3.1 only separates
// them once they move apart, after [KLK14]). The method is PCL's supervoxels + LCCP (Papon et
// al. 2013; Stein et al., "Object Partitioning using Local Convexity", CVPR 2014), run in its own
// library (mfot_discovery) behind this PCL-free interface; the per-frame clustering stays the
// cheap Euclidean one and discovery runs only at birth and, to confirm it, on the first
// confirm_frames frames of the objects born from a cluster.

#include <Eigen/Core>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "mfot/part_boundary.hpp"
#include "mfot/types.hpp"

namespace mfot {

enum class DiscoveryMethod {
  kClusters,  // a new object is a whole Euclidean cluster (the thesis)
  kLccp,      // a cluster is split into its locally convex connected parts
};

// Member defaults: the settings of PCL's example_lccp_segmentation; the services fill every field
// from configs/default.yaml (merger.discovery).
struct DiscoveryOptions {
  DiscoveryMethod method = DiscoveryMethod::kClusters;
  float voxel_resolution = 0.0075f;  // supervoxel voxel leaf, metres, (0, 0.1]
  float seed_resolution = 0.03f;     // supervoxel seed spacing, metres, [voxel_resolution, 0.5]
  float color_importance = 0.0f;     // supervoxel distance weights, each [0, 100]
  float spatial_importance = 1.0f;
  float normal_importance = 4.0f;
  float concavity_tolerance_deg = 10.f;  // a concave edge flatter than this still joins, (0, 90]
  float smoothness_threshold = 0.1f;     // LCCP's smoothness check (step between supervoxels), [0, 1]; 0 = off
  bool sanity_criterion = true;          // LCCP's sanity check of singular (edge-on) connections
  // Two supervoxels LCCP joins stay joined only while their mean colours' CIELab a*b* lie within this
  // of each other: touching objects whose faces are flush (no concave edge between them) come apart
  // by colour. [0, 200]; 0 = off (convexity alone).
  float color_cut = 0.f;
  // Parts with fewer points than this are no objects: their points join the neighbouring larger
  // part they touch (a label on a can, a handle seen edge-on, a bottle's neck and cap), >= 1. At
  // the scene's 5 mm voxels 400 points are 100 cm2 of seen surface: a neck 2-4 cm across shows
  // 160-260, a box that stands on or beside another one 500 and more.
  int min_part_points = 400;
  // Discovery confirmed over the first frames: in each of the confirm_frames frames after their
  // birth the discovery splits the segmented points of the objects born from one cluster again,
  // together, and once its parts disagreed with those objects in confirm_votes of those frames,
  // that frame's parts become the objects (ObjectManager step 7): touching objects that the birth
  // frame's sensor noise joined come apart in the frames after, each frame's noise being new.
  // confirm_frames [0, 1000], 0 = off (discovery at birth only); confirm_votes >= 1 and at most
  // confirm_frames. An object takes part only while it stays within confirm_max_motion (metres,
  // (0, 1]) of where it was born: a moving object (a hand reaching in) shows new parts of itself,
  // not new noise.
  int confirm_frames = 0;
  int confirm_votes = 3;
  float confirm_max_motion = 0.01f;
  // The other way round (with confirm_frames > 0): two objects born from one cluster whose points lay mostly in one
  // part in every frame they were split again, and in at least confirm_frames - confirm_votes + 1 of them, are one
  // object (the birth frame's noise cut it): when the first of them leaves the confirmation, the smaller joins the
  // larger. A pair seen apart in any frame stays apart: the discovery finds touching objects as one in some frames, so
  // agreeing frames alone say less than one frame that tells them apart.
  // Point-level boundaries between the parts by colour (part_boundary.hpp), applied to every split
  // by the ObjectManager; radius 0 = off (parts end at supervoxel borders).
  PartBoundaryOptions boundary;

  // Throws std::invalid_argument naming the field and its allowed range.
  void validate() const;
};

DiscoveryMethod parse_discovery_method(const std::string& name);  // "clusters" | "lccp", else throws

// Splits one connected set of scene points into objects.
class ObjectDiscovery {
 public:
  virtual ~ObjectDiscovery() = default;
  // positions/colors: the points of one cluster, camera frame (finite). part_of_point receives
  // (resized) each point's part in [0, parts), every point in one part; parts are numbered by
  // their first point. Returns the number of parts (>= 1 for a non-empty input). Deterministic.
  virtual int split(std::span<const Eigen::Vector3f> positions, std::span<const Rgb8> colors,
                    std::vector<int>& part_of_point) = 0;
};

// In mfot_discovery (PCL inside), for options that passed validate(): kClusters gives nullptr
// (nothing to split), kLccp the supervoxel + LCCP discovery.
__attribute__((visibility("default"))) std::unique_ptr<ObjectDiscovery> make_object_discovery(
    const DiscoveryOptions& options);
// One discovery per thread (threads in [1, 64], else std::invalid_argument): empty for kClusters.
__attribute__((visibility("default"))) std::vector<std::unique_ptr<ObjectDiscovery>> make_object_discoveries(
    const DiscoveryOptions& options, int threads);

}  // namespace mfot
