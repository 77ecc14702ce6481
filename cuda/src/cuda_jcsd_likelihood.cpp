// JCSD hypothesis evaluation on a CUDA GPU, thesis 3.3, equations 3.18 to 3.20: the host side
// (see the header for the steps). Packs the model grid, the hypothesis points and the particles
// into the pinned staging buffers of jcsd_device.cu, which runs the transfers and the kernel.

#include "mfot/cuda/cuda_jcsd_likelihood.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "jcsd_device.cuh"

namespace mfot {

void validate(const CudaJcsdLikelihoodOptions& options) {
  validate(options.grid);
  if (options.device < 0) {
    throw std::invalid_argument("CudaJcsdLikelihoodOptions.device must be >= 0, got " + std::to_string(options.device));
  }
  if (options.point_splits < 0 || options.point_splits > 64) {
    throw std::invalid_argument("CudaJcsdLikelihoodOptions.point_splits must be in [0, 64] (0: automatic), got " +
                                std::to_string(options.point_splits));
  }
}

CudaJcsdLikelihood::CudaJcsdLikelihood(const CudaJcsdLikelihoodOptions& options) : options_(options) {
  validate(options_);
  device_ =
      std::make_unique<cuda_detail::JcsdDevice>(cuda_detail::DeviceOptions{options_.device, options_.point_splits});
}

CudaJcsdLikelihood::~CudaJcsdLikelihood() = default;

void CudaJcsdLikelihood::set_model(const ObjectModel& model) { set_grid(build_jcsd_grid(model, options_.grid)); }

void CudaJcsdLikelihood::set_grid(JcsdGrid grid) {
  if (grid.values.size() != grid.num_corners() * kSmrBins) {
    throw std::invalid_argument("CudaJcsdLikelihood::set_grid: values.size() != dims product * 8");
  }
  if (!grid.empty() && (grid.dims[0] < 2 || grid.dims[1] < 2 || grid.dims[2] < 2)) {
    throw std::invalid_argument("CudaJcsdLikelihood::set_grid: every dimension needs >= 2 corners");
  }
  if (!grid.empty()) {
    float* staging = device_->grid_staging(grid.num_corners());
    std::copy(grid.values.begin(), grid.values.end(), staging);
    device_->upload_grid(grid.dims);
  }
  grid_ = std::move(grid);
}

void CudaJcsdLikelihood::evaluate(std::span<const Pose> particles, const HypothesisData& data,
                                  std::span<float> scores) {
  if (scores.size() != particles.size()) {
    throw std::invalid_argument("CudaJcsdLikelihood::evaluate: scores.size() != particles.size()");
  }
  if (data.features.size() != data.points.size()) {
    throw std::invalid_argument("CudaJcsdLikelihood::evaluate: data.features.size() != data.points.size()");
  }
  const std::size_t n = data.points.size();
  if (grid_.empty() || n == 0) {
    std::fill(scores.begin(), scores.end(), 0.f);
    return;
  }
  if (particles.empty()) return;

  const cuda_detail::FrameStaging frame = device_->stage_frame(n, particles.size());
  cuda_detail::PointRecord* points = frame.points;
  for (std::size_t j = 0; j < n; ++j) {
    const Eigen::Vector3f& z = data.points[j];
    const SmrFeature& h = data.features[j];
    // A bin outside the feature's range would index outside the device grid.
    if (h.hue_bin > 5 || (h.gray_bin != 6 && h.gray_bin != 7)) {
      throw std::invalid_argument("CudaJcsdLikelihood::evaluate: feature " + std::to_string(j) +
                                  " has hue_bin outside [0, 6) or gray_bin not 6 or 7");
    }
    points[j] = {z.x(),           z.y(),           z.z(),         static_cast<std::int32_t>(h.hue_bin),
                 h.hue_weight_lo, h.hue_weight_hi, h.gray_weight, static_cast<std::int32_t>(h.gray_bin)};
  }

  // u = (R^T (z - t) - origin) / cell = A z + b, A = R^T / cell, b = -(R^T t + origin) / cell.
  const float inv_cell = 1.f / grid_.cell_size;
  cuda_detail::ParticleRecord* records = frame.particles;
  for (std::size_t i = 0; i < particles.size(); ++i) {
    const Eigen::Matrix3f rt = particles[i].rotation.toRotationMatrix().transpose();
    const Eigen::Matrix3f a = rt * inv_cell;
    const Eigen::Vector3f b = -(rt * particles[i].translation + grid_.origin) * inv_cell;
    float* m = records[i].m;
    for (int r = 0; r < 3; ++r) {
      m[4 * r + 0] = a(r, 0);
      m[4 * r + 1] = a(r, 1);
      m[4 * r + 2] = a(r, 2);
      m[4 * r + 3] = b(r);
    }
  }
  device_->evaluate(n, particles.size(), scores.data());
}

CudaJcsdTiming CudaJcsdLikelihood::last_timing() const {
  const cuda_detail::DeviceTiming t = device_->last_timing();
  return {t.kernel_ms, t.transfer_ms, t.splits};
}

const std::string& CudaJcsdLikelihood::device_description() const { return device_->description(); }

}  // namespace mfot
