#pragma once
// Joint Color-Spatial Descriptor grid, thesis 3.2.2-3.2.3, Algorithm 3, equation 3.12.

#include "mfot/smr_feature.hpp"
#include "mfot/types.hpp"

#include <array>
#include <span>
#include <vector>

namespace mfot {

struct JcsdGridOptions {
  float cell_size = 0.015f;  // metres, the kernel bandwidth r
  int padding_cells = 1;     // cells added on every side of the bounding box
};

// The descriptor J (8 x m): for every grid corner s, eight colour densities.
// Memory layout (shared by the CPU and CUDA evaluators): corner-major, the eight colour values
// of one corner contiguous (32 bytes), corners ordered x fastest, then y, then z:
//   values[((iz * dims[1] + iy) * dims[0] + ix) * 8 + c].
struct JcsdGrid {
  Eigen::Vector3f origin = Eigen::Vector3f::Zero();  // position of corner (0,0,0), object frame, metres
  float cell_size = 0.015f;                          // metres
  std::array<int, 3> dims{0, 0, 0};                  // corners along x, y, z
  std::vector<float> values;                         // dims[0]*dims[1]*dims[2]*8

  std::size_t num_corners() const { return static_cast<std::size_t>(dims[0]) * dims[1] * dims[2]; }
  bool empty() const { return values.empty(); }
};

}  // namespace mfot
