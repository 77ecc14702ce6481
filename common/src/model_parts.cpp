#include "mfot/model_parts.hpp"

#include <algorithm>
#include <numeric>
#include <stdexcept>

#include "mfot/preprocessing.hpp"

namespace mfot {

std::vector<std::uint32_t> even_subset(const ColoredCloud& cloud, std::size_t max_points) {
  std::vector<std::uint32_t> chosen(cloud.size());
  std::iota(chosen.begin(), chosen.end(), 0u);
  const std::vector<std::uint32_t> all = chosen;
  for (float leaf = 0.002f; chosen.size() > max_points && leaf <= 1.f; leaf *= 1.25f) {
    VoxelDownsampler voxels(leaf);
    voxels.downsample(cloud.positions, cloud.colors, all);
    chosen.assign(voxels.first_source_ids().begin(), voxels.first_source_ids().end());
  }
  chosen.resize(std::min(chosen.size(), max_points));  // a cap below the voxels left at 1 m: the first ones
  return chosen;
}

ObjectModel thinned(ObjectModel model, std::size_t max_points, std::vector<std::uint32_t>& part_ends) {
  const std::vector<std::uint32_t> keep = even_subset(model.cloud, max_points);
  if (keep.size() == model.cloud.size()) return model;
  for (std::uint32_t& end : part_ends) {  // keep ascends: the points kept before each end
    end = static_cast<std::uint32_t>(std::lower_bound(keep.begin(), keep.end(), end) - keep.begin());
  }
  part_ends.erase(std::unique(part_ends.begin(), part_ends.end()), part_ends.end());
  if (!part_ends.empty() && part_ends.front() == 0) part_ends.erase(part_ends.begin());
  ObjectModel out;
  out.cloud.reserve(keep.size());
  out.features.reserve(keep.size());
  for (const std::uint32_t k : keep) {
    out.cloud.push_back(model.cloud.positions[k], model.cloud.colors[k]);
    out.features.push_back(model.features[k]);
  }
  return out;
}

ObjectModel with_part(ObjectModel model, std::span<const Eigen::Vector3f> points, std::span<const Rgb8> colors,
                      std::span<const SmrFeature> features, std::size_t max_points,
                      std::vector<std::uint32_t>& part_ends) {
  if (colors.size() != points.size() || features.size() != points.size()) {
    throw std::invalid_argument("with_part: " + std::to_string(points.size()) + " points, " +
                                std::to_string(colors.size()) + " colours, " + std::to_string(features.size()) +
                                " features");
  }
  for (std::size_t k = 0; k < points.size(); ++k) model.cloud.push_back(points[k], colors[k]);
  model.features.insert(model.features.end(), features.begin(), features.end());
  part_ends.push_back(static_cast<std::uint32_t>(model.cloud.size()));
  return thinned(std::move(model), max_points, part_ends);
}

}  // namespace mfot
