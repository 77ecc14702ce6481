#pragma once
// PCL's own object segmentation as a reference for mfot's discovery: a RANSAC table fit
// (pcl::SACSegmentation, 1 cm), then supervoxels + LCCP with the settings of PCL's
// example_lccp_segmentation (voxel 0.0075, seed 0.03, colour 0, spatial 1, normal 4; concavity
// 10 deg, smoothness 0.1, no k-factor, no sanity check, no minimum segment size). Its file is built
// for the baseline ISA like PCL itself.

#include <cstdint>
#include <vector>

namespace mfot::bench {

struct PclLccpResult {
  std::vector<std::int32_t> labels;  // per input point: segment (>= 1), 0 = table, no measurement or none
  double segment_ms = 0.0;           // supervoxels + LCCP (after the table fit)
  double table_ms = 0.0;             // the RANSAC table fit and removal
};

// xyz: 3 floats per point (metres, NaN = no measurement), rgb: 3 bytes per point.
PclLccpResult pcl_lccp_segments(const std::vector<float>& xyz, const std::vector<std::uint8_t>& rgb);

}  // namespace mfot::bench
