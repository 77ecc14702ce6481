// Joint Color-Spatial Descriptor grid, thesis 3.2.2-3.2.3, Algorithm 3, equations 3.12 and 3.18-3.19.
// Building: (1) bounding box of the points, padded by padding_cells on every side; (2) for each
// point, its cell and that cell's 8 corners; (3) J(c, s) += (1/n) h(c) K_r(|s - p|) with the
// triangular kernel K_r(d) = max(r - d, 0) / r, for the (at most 3) non-zero bins of h.

#include "mfot/jcsd_grid.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "mfot/likelihood.hpp"

namespace mfot {

void validate(const JcsdGridOptions& options) {
  if (!(std::isfinite(options.cell_size) && options.cell_size > 0.f && options.cell_size <= 1.f)) {
    throw std::invalid_argument("JcsdGridOptions.cell_size must be in (0, 1] metres, got " +
                                std::to_string(options.cell_size));
  }
  if (options.padding_cells < 1 || options.padding_cells > 16) {
    throw std::invalid_argument("JcsdGridOptions.padding_cells must be in [1, 16], got " +
                                std::to_string(options.padding_cells));
  }
}

JcsdGrid build_jcsd_grid(std::span<const Eigen::Vector3f> positions, std::span<const SmrFeature> features,
                         const JcsdGridOptions& options, JcsdBuildStats* stats) {
  validate(options);
  if (positions.size() != features.size()) {
    throw std::invalid_argument("build_jcsd_grid: positions and features differ in length");
  }
  JcsdGrid grid;
  grid.cell_size = options.cell_size;
  if (stats != nullptr) *stats = {};
  if (positions.empty()) return grid;

  Eigen::Vector3f lo = positions[0];
  Eigen::Vector3f hi = positions[0];
  for (const Eigen::Vector3f& p : positions) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const float r = options.cell_size;
  const int pad = options.padding_cells;
  grid.origin = lo - Eigen::Vector3f::Constant(static_cast<float>(pad) * r);
  // Checked before any conversion to int: far-apart (or non-finite) points would otherwise ask for
  // an unbounded grid.
  double corners = 1.0;
  for (int a = 0; a < 3; ++a) corners *= std::floor(static_cast<double>(hi[a] - lo[a]) / r) + 2.0 + 2.0 * pad;
  if (!(corners <= static_cast<double>(kJcsdMaxCorners))) {
    throw std::invalid_argument("build_jcsd_grid: points spanning " + std::to_string(hi.x() - lo.x()) + " x " +
                                std::to_string(hi.y() - lo.y()) + " x " + std::to_string(hi.z() - lo.z()) +
                                " m need more than " + std::to_string(kJcsdMaxCorners) + " grid corners at cell " +
                                std::to_string(r) + " m");
  }
  for (int a = 0; a < 3; ++a) {
    const int cells = static_cast<int>(std::floor((hi[a] - lo[a]) / r)) + 1 + 2 * pad;
    grid.dims[a] = cells + 1;
  }
  grid.values.assign(grid.num_corners() * kSmrBins, 0.f);

  const float inv_n = 1.f / static_cast<float>(positions.size());
  const float inv_r = 1.f / r;
  const std::size_t stride_y = static_cast<std::size_t>(grid.dims[0]);
  const std::size_t stride_z = stride_y * static_cast<std::size_t>(grid.dims[1]);
  std::size_t kernel_evaluations = 0;
  for (std::size_t k = 0; k < positions.size(); ++k) {
    const Eigen::Vector3f u = (positions[k] - grid.origin) * inv_r;
    std::array<int, 3> cell{};
    for (int a = 0; a < 3; ++a) {
      // Clamp against rounding at the upper face; the padding keeps real points inside.
      cell[a] = std::clamp(static_cast<int>(std::floor(u[a])), 0, grid.dims[a] - 2);
    }
    const SmrFeature& h = features[k];
    const int bin_hi = (h.hue_bin + 1) % 6;
    for (int corner = 0; corner < 8; ++corner) {
      const int cx = cell[0] + (corner & 1);
      const int cy = cell[1] + ((corner >> 1) & 1);
      const int cz = cell[2] + ((corner >> 2) & 1);
      const Eigen::Vector3f s =
          grid.origin + r * Eigen::Vector3f(static_cast<float>(cx), static_cast<float>(cy), static_cast<float>(cz));
      const float kernel = std::max(r - (s - positions[k]).norm(), 0.f) * inv_r;  // 3.12
      ++kernel_evaluations;
      if (kernel == 0.f) continue;
      const float w = inv_n * kernel;
      float* J = grid.values.data() + (static_cast<std::size_t>(cz) * stride_z +
                                       static_cast<std::size_t>(cy) * stride_y + static_cast<std::size_t>(cx)) *
                                          kSmrBins;
      J[h.hue_bin] += w * h.hue_weight_lo;
      J[bin_hi] += w * h.hue_weight_hi;
      J[h.gray_bin] += w * h.gray_weight;
    }
  }
  if (stats != nullptr) {
    stats->points = positions.size();
    stats->kernel_evaluations = kernel_evaluations;
  }
  return grid;
}

JcsdGrid build_jcsd_grid(const ObjectModel& model, const JcsdGridOptions& options, JcsdBuildStats* stats) {
  if (model.cloud.size() != model.features.size()) {
    throw std::invalid_argument("build_jcsd_grid: model.cloud and model.features differ in length");
  }
  return build_jcsd_grid(model.cloud.positions, model.features, options, stats);
}

float jcsd_point_score(const JcsdGrid& grid, const Eigen::Vector3f& p_object, const SmrFeature& h) {
  if (grid.empty()) return 0.f;
  const Eigen::Vector3f u = (p_object - grid.origin) / grid.cell_size;
  std::array<int, 3> cell{};
  std::array<float, 3> frac{};
  for (int a = 0; a < 3; ++a) {
    const float f = std::floor(u[a]);
    if (!(f >= 0.f && f <= static_cast<float>(grid.dims[a] - 2))) return 0.f;
    cell[a] = static_cast<int>(f);
    frac[a] = u[a] - f;
  }
  const std::array<float, kSmrBins> dense = h.dense();
  float score = 0.f;
  for (int corner = 0; corner < 8; ++corner) {
    const int ox = corner & 1;
    const int oy = (corner >> 1) & 1;
    const int oz = (corner >> 2) & 1;
    // 3.18: the weight of a corner is the product over axes of (1 - |z - s| / l).
    const float weight =
        (ox ? frac[0] : 1.f - frac[0]) * (oy ? frac[1] : 1.f - frac[1]) * (oz ? frac[2] : 1.f - frac[2]);
    const std::size_t index =
        ((static_cast<std::size_t>(cell[2] + oz) * grid.dims[1] + (cell[1] + oy)) * grid.dims[0] + (cell[0] + ox)) *
        kSmrBins;
    float correlation = 0.f;  // 3.19
    for (int c = 0; c < kSmrBins; ++c) correlation += dense[c] * grid.values[index + c];
    score += weight * correlation;
  }
  return score;
}

}  // namespace mfot
