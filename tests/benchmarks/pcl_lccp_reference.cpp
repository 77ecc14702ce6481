#include "pcl_lccp_reference.hpp"

#include <pcl/ModelCoefficients.h>
#include <pcl/filters/extract_indices.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/segmentation/lccp_segmentation.h>
#include <pcl/segmentation/sac_segmentation.h>
#include <pcl/segmentation/supervoxel_clustering.h>

#include <chrono>
#include <cmath>
#include <map>

namespace mfot::bench {

PclLccpResult pcl_lccp_segments(const std::vector<float>& xyz, const std::vector<std::uint8_t>& rgb) {
  using PointT = pcl::PointXYZRGBA;
  using Clock = std::chrono::steady_clock;
  const std::size_t n = xyz.size() / 3;
  PclLccpResult result;
  result.labels.assign(n, 0);
  const auto cloud = pcl::make_shared<pcl::PointCloud<PointT>>();
  std::vector<std::size_t> source;  // cloud index -> input point
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(xyz[3 * i + 2])) continue;
    PointT p;
    p.x = xyz[3 * i];
    p.y = xyz[3 * i + 1];
    p.z = xyz[3 * i + 2];
    p.r = rgb[3 * i];
    p.g = rgb[3 * i + 1];
    p.b = rgb[3 * i + 2];
    p.a = 255;
    cloud->push_back(p);
    source.push_back(i);
  }
  const auto t0 = Clock::now();
  pcl::SACSegmentation<PointT> plane;
  plane.setOptimizeCoefficients(true);
  plane.setModelType(pcl::SACMODEL_PLANE);
  plane.setMethodType(pcl::SAC_RANSAC);
  plane.setDistanceThreshold(0.01);
  plane.setInputCloud(cloud);
  pcl::PointIndices::Ptr inliers(new pcl::PointIndices);
  pcl::ModelCoefficients coefficients;
  plane.segment(*inliers, coefficients);
  std::vector<bool> on_table(cloud->size(), false);
  for (const int i : inliers->indices) on_table[static_cast<std::size_t>(i)] = true;
  const auto objects = pcl::make_shared<pcl::PointCloud<PointT>>();
  std::vector<std::size_t> object_source;
  for (std::size_t i = 0; i < cloud->size(); ++i) {
    if (on_table[i]) continue;
    objects->push_back((*cloud)[i]);
    object_source.push_back(source[i]);
  }
  const auto t1 = Clock::now();
  result.table_ms = std::chrono::duration<double, std::milli>(t1 - t0).count();
  if (objects->empty()) return result;

  const float voxel = 0.0075f, seed = 0.03f;
  pcl::SupervoxelClustering<PointT> supervoxels(voxel, seed);
  supervoxels.setUseSingleCameraTransform(false);
  supervoxels.setInputCloud(objects);
  supervoxels.setColorImportance(0.f);
  supervoxels.setSpatialImportance(1.f);
  supervoxels.setNormalImportance(4.f);
  std::map<std::uint32_t, pcl::Supervoxel<PointT>::Ptr> clusters;
  supervoxels.extract(clusters);
  std::multimap<std::uint32_t, std::uint32_t> adjacency;
  supervoxels.getSupervoxelAdjacency(adjacency);
  pcl::LCCPSegmentation<PointT> lccp;
  lccp.setConcavityToleranceThreshold(10.f);
  lccp.setSanityCheck(false);
  lccp.setSmoothnessCheck(true, voxel, seed, 0.1f);
  lccp.setKFactor(0);
  lccp.setMinSegmentSize(0);
  lccp.setInputSupervoxels(clusters, adjacency);
  lccp.segment();
  const pcl::PointCloud<pcl::PointXYZL>::Ptr labeled = supervoxels.getLabeledCloud();
  lccp.relabelCloud(*labeled);
  result.segment_ms = std::chrono::duration<double, std::milli>(Clock::now() - t1).count();
  for (std::size_t i = 0; i < labeled->size(); ++i) {
    result.labels[object_source[i]] = static_cast<std::int32_t>((*labeled)[i].label);
  }
  return result;
}

}  // namespace mfot::bench
