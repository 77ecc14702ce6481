#pragma once
// An organised PCD file (PCL's point cloud format, as PCL's grabbers and recorders write them) read
// with PCL's own PCD reader, in plain types: PCL and its Eigen stay inside mfot_pcd_reader (built,
// like PCL, for the baseline ISA, with hidden symbols).

#include <cstdint>
#include <string>
#include <vector>

namespace mfot::capture {

struct PcdImage {
  int width = 0;                     // columns of the organised cloud
  int height = 0;                    // rows
  std::vector<float> xyz;            // 3 per point, metres, camera frame; NaN = no measurement
  std::vector<std::uint8_t> rgb;     // 3 per point
  std::vector<std::uint32_t> label;  // one per point when the file has a `label` field (ground truth), else empty
};

// Reads `path`; false with `error` saying why (unreadable, truncated, not organised, no x y z or no
// rgb/rgba field).
__attribute__((visibility("default"))) bool read_organised_pcd(const std::string& path, PcdImage& out,
                                                               std::string& error);

}  // namespace mfot::capture
