#include "mfot/object_discovery.hpp"

#include <stdexcept>

namespace mfot {
namespace {

void require_range(const char* field, float value, float low, float high) {
  if (!(value >= low && value <= high)) {
    throw std::invalid_argument(std::string("DiscoveryOptions.") + field + " must be in [" + std::to_string(low) +
                                ", " + std::to_string(high) + "], got " + std::to_string(value));
  }
}

}  // namespace

void DiscoveryOptions::validate() const {
  if (!(voxel_resolution > 0.f && voxel_resolution <= 0.1f)) {
    throw std::invalid_argument("DiscoveryOptions.voxel_resolution must be in (0, 0.1] m, got " +
                                std::to_string(voxel_resolution));
  }
  require_range("seed_resolution", seed_resolution, voxel_resolution, 0.5f);
  require_range("color_importance", color_importance, 0.f, 100.f);
  require_range("spatial_importance", spatial_importance, 0.f, 100.f);
  require_range("normal_importance", normal_importance, 0.f, 100.f);
  if (!(concavity_tolerance_deg > 0.f && concavity_tolerance_deg <= 90.f)) {
    throw std::invalid_argument("DiscoveryOptions.concavity_tolerance_deg must be in (0, 90], got " +
                                std::to_string(concavity_tolerance_deg));
  }
  require_range("color_cut", color_cut, 0.f, 200.f);
  require_range("smoothness_threshold", smoothness_threshold, 0.f, 1.f);
  if (min_part_points < 1) {
    throw std::invalid_argument("DiscoveryOptions.min_part_points must be >= 1, got " +
                                std::to_string(min_part_points));
  }
  if (confirm_frames < 0 || confirm_frames > 1000) {
    throw std::invalid_argument("DiscoveryOptions.confirm_frames must be in [0, 1000], got " +
                                std::to_string(confirm_frames));
  }
  if (confirm_votes < 1 || (confirm_frames > 0 && confirm_votes > confirm_frames)) {
    throw std::invalid_argument("DiscoveryOptions.confirm_votes must be >= 1 and at most confirm_frames (" +
                                std::to_string(confirm_frames) + "), got " + std::to_string(confirm_votes));
  }
  if (!(confirm_max_motion > 0.f && confirm_max_motion <= 1.f)) {
    throw std::invalid_argument("DiscoveryOptions.confirm_max_motion must be in (0, 1] m, got " +
                                std::to_string(confirm_max_motion));
  }
  boundary.validate();
}

DiscoveryMethod parse_discovery_method(const std::string& name) {
  if (name == "clusters") return DiscoveryMethod::kClusters;
  if (name == "lccp") return DiscoveryMethod::kLccp;
  throw std::invalid_argument("discovery method must be clusters or lccp, got '" + name + "'");
}

}  // namespace mfot
