// Object discovery with PCL's supervoxels and LCCP (see mfot/object_discovery.hpp). Built like PCL
// for the baseline ISA with hidden symbols: PCL's Eigen code stays apart from the core's.
//
// Steps of LccpDiscovery::split:
//   1. supervoxels of the cluster's points (voxel_resolution, seed_resolution, the three
//      importances; no single-camera transform: the points are already voxel means);
//   2. LCCP over the supervoxel adjacency graph: neighbours join when their connection is convex,
//      or concave by less than concavity_tolerance_deg, with the smoothness, k-factor and sanity
//      checks as configured;
//   3. every point takes its LCCP segment (points in no supervoxel: none);
//   4. segments of at least min_part_points are parts; the points of the others (and of none) join
//      the part of their nearest point in a part, so tiny pieces never become objects;
//   5. parts are numbered by their first point. Fewer than two parts: the cluster is one object.

#include "mfot/object_discovery.hpp"

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/lccp_segmentation.h>
#include <pcl/segmentation/supervoxel_clustering.h>

#include <cstdint>
#include <map>
#include <unordered_map>

namespace mfot {
namespace {

using PointT = pcl::PointXYZRGBA;

class LccpDiscovery final : public ObjectDiscovery {
 public:
  explicit LccpDiscovery(const DiscoveryOptions& options) : options_(options) {}
  LccpDiscovery(const LccpDiscovery&) = delete;
  LccpDiscovery& operator=(const LccpDiscovery&) = delete;

  int split(std::span<const Eigen::Vector3f> positions, std::span<const Rgb8> colors,
            std::vector<int>& part_of_point) override {
    part_of_point.assign(positions.size(), 0);
    if (positions.empty()) return 0;
    const auto cloud = pcl::make_shared<pcl::PointCloud<PointT>>();
    cloud->resize(positions.size());
    for (std::size_t i = 0; i < positions.size(); ++i) {
      PointT& p = (*cloud)[i];
      p.x = positions[i].x();
      p.y = positions[i].y();
      p.z = positions[i].z();
      p.r = colors[i].r;
      p.g = colors[i].g;
      p.b = colors[i].b;
      p.a = 255;
    }

    // 1. supervoxels
    pcl::SupervoxelClustering<PointT> supervoxels(options_.voxel_resolution, options_.seed_resolution);
    supervoxels.setUseSingleCameraTransform(false);
    supervoxels.setInputCloud(cloud);
    supervoxels.setColorImportance(options_.color_importance);
    supervoxels.setSpatialImportance(options_.spatial_importance);
    supervoxels.setNormalImportance(options_.normal_importance);
    std::map<std::uint32_t, pcl::Supervoxel<PointT>::Ptr> clusters;
    supervoxels.extract(clusters);
    if (clusters.size() < 2) return 1;
    std::multimap<std::uint32_t, std::uint32_t> adjacency;
    supervoxels.getSupervoxelAdjacency(adjacency);

    // 2. LCCP
    pcl::LCCPSegmentation<PointT> lccp;
    lccp.setConcavityToleranceThreshold(options_.concavity_tolerance_deg);
    lccp.setSanityCheck(options_.sanity_criterion);
    lccp.setSmoothnessCheck(options_.smoothness_threshold > 0.f, options_.voxel_resolution, options_.seed_resolution,
                            options_.smoothness_threshold);
    lccp.setKFactor(options_.extended_convexity ? 1u : 0u);
    lccp.setMinSegmentSize(0);
    lccp.setInputSupervoxels(clusters, adjacency);
    lccp.segment();

    // 3. a segment per point (getLabeledCloud keeps the input's order; 0 = in no supervoxel)
    const pcl::PointCloud<pcl::PointXYZL>::Ptr labeled = supervoxels.getLabeledCloud();
    lccp.relabelCloud(*labeled);
    std::unordered_map<std::uint32_t, std::size_t> sizes;
    for (const auto& p : labeled->points) {
      if (p.label != 0) ++sizes[p.label];
    }

    // 4. parts and what joins them
    const auto is_part = [&](std::uint32_t label) {
      return label != 0 && sizes[label] >= static_cast<std::size_t>(options_.min_part_points);
    };
    std::vector<int> in_parts;
    for (std::size_t i = 0; i < positions.size(); ++i) {
      if (is_part((*labeled)[i].label)) in_parts.push_back(static_cast<int>(i));
    }
    if (in_parts.empty()) return 1;
    std::vector<std::uint32_t> label(positions.size());
    for (std::size_t i = 0; i < positions.size(); ++i) label[i] = (*labeled)[i].label;
    if (in_parts.size() < positions.size()) {
      const auto part_cloud = pcl::make_shared<pcl::PointCloud<PointT>>();
      for (const int i : in_parts) part_cloud->push_back((*cloud)[static_cast<std::size_t>(i)]);
      pcl::search::KdTree<PointT> tree;
      tree.setInputCloud(part_cloud);
      pcl::Indices nearest(1);
      std::vector<float> distances(1);
      for (std::size_t i = 0; i < positions.size(); ++i) {
        if (is_part(label[i])) continue;
        tree.nearestKSearch((*cloud)[i], 1, nearest, distances);
        label[i] = (*labeled)[static_cast<std::size_t>(in_parts[static_cast<std::size_t>(nearest[0])])].label;
      }
    }

    // 5. parts numbered by their first point
    std::unordered_map<std::uint32_t, int> part_of_label;
    for (std::size_t i = 0; i < positions.size(); ++i) {
      const auto [it, inserted] = part_of_label.try_emplace(label[i], static_cast<int>(part_of_label.size()));
      part_of_point[i] = it->second;
    }
    if (part_of_label.size() < 2) std::fill(part_of_point.begin(), part_of_point.end(), 0);
    return static_cast<int>(std::max<std::size_t>(part_of_label.size(), 1));
  }

 private:
  DiscoveryOptions options_;
};

}  // namespace

std::unique_ptr<ObjectDiscovery> make_object_discovery(const DiscoveryOptions& options) {
  if (options.method == DiscoveryMethod::kClusters) return nullptr;
  return std::make_unique<LccpDiscovery>(options);
}

}  // namespace mfot
