#pragma once
// The voxel grid of a preprocessed frame: cubes of edge `leaf` laid from `corner` (both metres,
// camera frame), so the voxel of a point p is the cell floor((p - corner) / leaf). With
// voxel_jitter the corner moves every frame, and what maps a frame's pixels to its voxels (the
// label images) needs that frame's leaf and corner together: one value, so they cannot be passed apart.

#include <Eigen/Core>

namespace mfot {

struct VoxelGrid {
  float leaf = 0.f;                                  // metres (0: no grid yet)
  Eigen::Vector3f corner = Eigen::Vector3f::Zero();  // a corner of the cells, metres

  // The cell of p (within 2^31 leaves of the corner), by the arithmetic of VoxelDownsampler's keys:
  // a product with the reciprocal, which may differ from the quotient in a boundary's last bit.
  Eigen::Vector3i cell_of(const Eigen::Vector3f& p) const {
    return ((p - corner) * (1.f / leaf)).array().floor().cast<int>().matrix();
  }
};

}  // namespace mfot
