// Object discovery with PCL's supervoxels and LCCP (see mfot/object_discovery.hpp). Built like PCL
// for the baseline ISA with hidden symbols: PCL's Eigen code stays apart from the core's.
//
// Steps of LccpDiscovery::split:
//   1. supervoxels of the cluster's points (voxel_resolution, seed_resolution, the three
//      importances; no single-camera transform: the points are already voxel means);
//   2. LCCP over the supervoxel adjacency graph: neighbours join when their connection is convex,
//      or concave by less than concavity_tolerance_deg, with the smoothness, k-factor and sanity
//      checks as configured;
//   3. every point takes its LCCP segment (points in no supervoxel: none); with color_cut, the segments
//      are grown again over LCCP's valid connections between supervoxels whose mean colours (CIELab
//      a*b* at one lightness) lie within color_cut: touching objects whose faces are flush or whose
//      caps are level, so that a convex or flat path joins them, come apart by colour;
//   4. segments of at least min_part_points are parts; the points of the others (and of none) join
//      the part of their nearest point in a part, so tiny pieces never become objects;
//   5. parts are numbered by their first point. Fewer than two parts: the cluster is one object.

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/lccp_segmentation.h>
#include <pcl/segmentation/supervoxel_clustering.h>

#include <cmath>
#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "mfot/object_discovery.hpp"

namespace mfot {
namespace {

using PointT = pcl::PointXYZRGBA;

// CIELab a*, b* of an sRGB colour (D65), brought to lightness 50: the hue and saturation without the
// shading that darkens one object's faces unequally (a*, b* and L* + 16 all scale with the cube root of
// the light). Below L* 20 the colour counts as of L* 20, so the noise of dark colours is not amplified.
Eigen::Vector2f chroma(const PointT& p) {
  const auto linear = [](std::uint8_t c) {
    const float v = static_cast<float>(c) / 255.f;
    return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
  };
  const float r = linear(p.r), g = linear(p.g), b = linear(p.b);
  const float x = (0.4124f * r + 0.3576f * g + 0.1805f * b) / 0.95047f;
  const float y = 0.2126f * r + 0.7152f * g + 0.0722f * b;
  const float z = (0.0193f * r + 0.1192f * g + 0.9505f * b) / 1.08883f;
  const auto f = [](float t) { return t > 0.008856f ? std::cbrt(t) : 7.787f * t + 16.f / 116.f; };
  const float lightness = 116.f * f(y) - 16.f;
  const float scale = 66.f / (std::max(lightness, 20.f) + 16.f);
  return {scale * 500.f * (f(x) - f(y)), scale * 200.f * (f(y) - f(z))};
}

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
    lccp.setKFactor(0u);  // no extended convexity (PCL's example): it splits boxes' faces apart
    lccp.setMinSegmentSize(0);
    lccp.setInputSupervoxels(clusters, adjacency);
    lccp.segment();

    // 3. a segment per point (getLabeledCloud keeps the input's order; 0 = in no supervoxel)
    const pcl::PointCloud<pcl::PointXYZL>::Ptr labeled = supervoxels.getLabeledCloud();
    if (options_.color_cut > 0.f) {
      join_by_convexity_and_color(lccp, clusters, *labeled);
    } else {
      lccp.relabelCloud(*labeled);
    }
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
  // LCCP's region growing again, over the connections LCCP found valid (convex, or concave within the
  // tolerance) whose supervoxels' mean colours lie within color_cut of each other (CIELab a*b*): the label of
  // every point becomes its component's lowest supervoxel label.
  void join_by_convexity_and_color(const pcl::LCCPSegmentation<PointT>& lccp,
                                   const std::map<std::uint32_t, pcl::Supervoxel<PointT>::Ptr>& clusters,
                                   pcl::PointCloud<pcl::PointXYZL>& labeled) const {
    typename pcl::LCCPSegmentation<PointT>::SupervoxelAdjacencyList graph;
    lccp.getSVAdjacencyList(graph);
    std::unordered_map<std::uint32_t, std::uint32_t> parent;
    const auto find = [&](std::uint32_t a) {
      while (parent.at(a) != a) a = parent[a] = parent.at(parent[a]);
      return a;
    };
    std::unordered_map<std::uint32_t, Eigen::Vector2f> ab;
    for (const auto& [label, supervoxel] : clusters) {
      parent[label] = label;
      ab[label] = chroma(supervoxel->centroid_);
    }
    const auto [first, last] = boost::edges(graph);
    for (auto e = first; e != last; ++e) {
      if (!graph[*e].is_valid) continue;
      const std::uint32_t a = graph[boost::source(*e, graph)], b = graph[boost::target(*e, graph)];
      if (!parent.contains(a) || !parent.contains(b)) continue;
      if ((ab[a] - ab[b]).norm() > options_.color_cut) continue;
      const std::uint32_t ra = find(a), rb = find(b);
      if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
    }
    for (auto& p : labeled.points) {
      if (p.label != 0 && parent.contains(p.label)) p.label = find(p.label);
    }
  }

  DiscoveryOptions options_;
};

}  // namespace

std::unique_ptr<ObjectDiscovery> make_object_discovery(const DiscoveryOptions& options) {
  if (options.method == DiscoveryMethod::kClusters) return nullptr;
  return std::make_unique<LccpDiscovery>(options);
}

std::vector<std::unique_ptr<ObjectDiscovery>> make_object_discoveries(const DiscoveryOptions& options, int threads) {
  if (threads < 1 || threads > 64) {
    throw std::invalid_argument("make_object_discoveries: threads must be in [1, 64], got " + std::to_string(threads));
  }
  std::vector<std::unique_ptr<ObjectDiscovery>> discoveries;
  if (options.method == DiscoveryMethod::kClusters) return discoveries;
  for (int t = 0; t < threads; ++t) discoveries.push_back(std::make_unique<LccpDiscovery>(options));
  return discoveries;
}

}  // namespace mfot
