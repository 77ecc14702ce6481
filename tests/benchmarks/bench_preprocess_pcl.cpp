#include "bench_preprocess_pcl.hpp"

#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <chrono>

namespace mfot::bench {

PclVoxelGridResult pcl_voxel_grid(const std::vector<float>& xyz, const std::vector<std::uint8_t>& rgb, float leaf,
                                  int repetitions) {
  const std::size_t n = xyz.size() / 3;
  pcl::PointCloud<pcl::PointXYZRGB>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZRGB>);
  cloud->resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    pcl::PointXYZRGB& q = (*cloud)[i];
    q.x = xyz[3 * i];
    q.y = xyz[3 * i + 1];
    q.z = xyz[3 * i + 2];
    q.r = rgb[3 * i];
    q.g = rgb[3 * i + 1];
    q.b = rgb[3 * i + 2];
  }
  pcl::VoxelGrid<pcl::PointXYZRGB> grid;
  grid.setLeafSize(leaf, leaf, leaf);
  grid.setInputCloud(cloud);
  pcl::PointCloud<pcl::PointXYZRGB> filtered;
  grid.filter(filtered);  // warm-up

  PclVoxelGridResult result;
  for (int r = 0; r < repetitions; ++r) {
    const auto start = std::chrono::steady_clock::now();
    grid.filter(filtered);
    result.filter_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  }
  result.voxels = filtered.size();
  return result;
}

}  // namespace mfot::bench
