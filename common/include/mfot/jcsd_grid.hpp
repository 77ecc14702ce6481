#pragma once
// Joint Color-Spatial Descriptor grid, thesis 3.2.2-3.2.3, Algorithm 3, equation 3.12.

#include <array>
#include <cstddef>
#include <span>
#include <vector>

#include "mfot/smr_feature.hpp"
#include "mfot/types.hpp"

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

// Instrumentation of one build: lets tests check that Algorithm 3 stays linear in n.
struct JcsdBuildStats {
  std::size_t points = 0;              // model points accumulated
  std::size_t kernel_evaluations = 0;  // K_r(|s - p|) evaluations (8 per point)
};

struct ObjectModel;

// Throws std::invalid_argument unless cell_size is finite and in (0, 1] m and padding_cells is in
// [1, 16] (at least one cell so every point's cell has all eight corners inside the grid).
void validate(const JcsdGridOptions& options);

// Upper bound on a grid's corners (8 floats each: 512 MiB): a 2 m cube at the default 1.5 cm cell
// needs 2.4M.
inline constexpr std::size_t kJcsdMaxCorners = std::size_t{1} << 24;

// Algorithm 3: J(c, s) += (1/n) h(c) K_r(|s - p|) over the 8 corners s of each point's cell, with
// the triangular kernel K_r(d) = max(r - d, 0) / r (3.12). The grid spans the points' bounding
// box padded by padding_cells on every side. O(n) in the number of points. An empty point set
// gives an empty grid. positions and features must have the same length; throws
// std::invalid_argument when the grid would exceed kJcsdMaxCorners.
JcsdGrid build_jcsd_grid(std::span<const Eigen::Vector3f> positions, std::span<const SmrFeature> features,
                         const JcsdGridOptions& options = {}, JcsdBuildStats* stats = nullptr);
JcsdGrid build_jcsd_grid(const ObjectModel& model, const JcsdGridOptions& options = {},
                         JcsdBuildStats* stats = nullptr);

// Reference (unoptimised) evaluation of one point, equations 3.18 and 3.19: trilinear
// interpolation of J at the 8 corners of the cell holding p_object, correlated with h.
// Returns 0 for points whose cell is not entirely inside the grid.
float jcsd_point_score(const JcsdGrid& grid, const Eigen::Vector3f& p_object, const SmrFeature& h);

}  // namespace mfot
