#pragma once
// pcl::VoxelGrid behind a plain interface. Its file is compiled without -march=native: PCL is
// built for the baseline ISA and Eigen's alignment would differ inside its headers otherwise.

#include <cstddef>
#include <cstdint>
#include <vector>

namespace mfot::bench {

struct PclVoxelGridResult {
  std::vector<double> filter_ms;  // one per repetition, pcl::VoxelGrid::filter only
  std::size_t voxels = 0;         // output size of the last repetition
};

// xyz: 3 floats per point (metres), rgb: 3 bytes per point.
PclVoxelGridResult pcl_voxel_grid(const std::vector<float>& xyz, const std::vector<std::uint8_t>& rgb, float leaf,
                                  int repetitions);

}  // namespace mfot::bench
