#include "mfot/preprocessing.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

#include "mfot/splitmix.hpp"

namespace mfot {

namespace {

using Clock = std::chrono::steady_clock;

double ms_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

void require(bool ok, const char* field, const std::string& range) {
  if (!ok) throw std::invalid_argument(std::string("PreprocessorOptions.") + field + " must be " + range);
}

bool finite_in(float v, float lo, float hi) { return std::isfinite(v) && v > lo && v <= hi; }

constexpr float kMetresPerMillimetre = 0.001f;
constexpr int kMaxImageSide = 32767;  // pixel coordinates travel as int16

// The voxel grid's corner for one frame: uniform in [0, leaf)^3, drawn by SplitMix64 from the seed and the frame's
// seq alone (a replay that skips frames draws the same grids for the frames it keeps).
Eigen::Vector3f jittered_grid_origin(std::uint64_t seed, std::int64_t frame_seq, float leaf) {
  std::uint64_t state = seed ^ (static_cast<std::uint64_t>(frame_seq) * 0xD1B54A32D192ED03ull);
  Eigen::Vector3f origin;
  for (int axis = 0; axis < 3; ++axis) origin[axis] = leaf * unit_interval(splitmix64(state));
  return origin;
}

}  // namespace

void SceneCloud::clear() {
  positions.clear();
  colors.clear();
  pixel_u.clear();
  pixel_v.clear();
  cluster.clear();
  num_clusters = 0;
  standing_clusters = 0;
  plane = TablePlane{};
  voxel_grid = VoxelGrid{};
}

void PreprocessorOptions::validate() const {
  for (int axis = 0; axis < 3; ++axis) {
    require(std::isfinite(crop_min[axis]) && std::isfinite(crop_max[axis]) && crop_min[axis] < crop_max[axis],
            "crop_min/crop_max", "finite with crop_min < crop_max on every axis");
  }
  plane_fit.validate();
  require(std::isfinite(plane_margin) && plane_margin >= 0.f && plane_margin <= 0.5f, "plane_margin",
          "in [0, 0.5] metres");
  require(std::isfinite(plane_margin_sigmas) && plane_margin_sigmas >= 0.f && plane_margin_sigmas <= 10.f,
          "plane_margin_sigmas", "in [0, 10]");
  require(depth_sigma.allFinite() && (depth_sigma.array() >= 0.f).all() && (depth_sigma.array() <= 1.f).all(),
          "depth_sigma", "base, quadratic and reference each in [0, 1]");
  require(finite_in(prism_min_share, 0.f, 1.f), "prism_min_share", "in (0, 1]");
  require(finite_in(plane_keep_ratio, 0.f, 1.f), "plane_keep_ratio", "in (0, 1]");
  require(finite_in(voxel_size, 0.f, 1.f), "voxel_size", "in (0, 1] metres");
  require(finite_in(cluster_tolerance, 0.f, 1.f), "cluster_tolerance", "in (0, 1] metres");
  require(cluster_min_size >= 1, "cluster_min_size", ">= 1");
  require(threads >= 1 && threads <= 64, "threads", "in [1, 64]");
}

Preprocessor::Preprocessor(PreprocessorOptions options)
    : options_((options.validate(), options)),
      pool_(options_.threads),
      plane_fitter_(options_.plane_fit),
      voxels_(options_.voxel_size) {}

void Preprocessor::reset_plane() {
  plane_ = TablePlane{};
  plane_fitted_share_ = 0.f;
}

const SceneCloud& Preprocessor::process(const RgbdImageView& image, std::int64_t frame_seq) {
  const auto t0 = Clock::now();
  stats_ = PreprocessStats{};

  backproject_and_crop(image);
  const auto t1 = Clock::now();

  remove_table();
  const auto t2 = Clock::now();

  const std::span<const Eigen::Vector3f> kept_positions =
      kept_all_cropped_ ? std::span<const Eigen::Vector3f>(cropped_positions_.data(), cropped_count_)
                        : std::span<const Eigen::Vector3f>(above_positions_.data(), above_count_);
  const std::span<const Rgb8> kept_colors = kept_all_cropped_
                                                ? std::span<const Rgb8>(cropped_colors_.data(), cropped_count_)
                                                : std::span<const Rgb8>(above_colors_.data(), above_count_);
  const std::span<const std::uint32_t> kept_pixels =
      kept_all_cropped_ ? std::span<const std::uint32_t>(cropped_pixels_.data(), cropped_count_)
                        : std::span<const std::uint32_t>(above_pixels_.data(), above_count_);
  stats_.above_plane = kept_positions.size();

  if (options_.voxel_jitter) {
    voxels_.set_grid_origin(jittered_grid_origin(options_.voxel_jitter_seed, frame_seq, options_.voxel_size));
  }
  const std::size_t voxel_count = voxels_.downsample(kept_positions, kept_colors, kept_pixels, &pool_);
  stats_.voxels = voxel_count;

  // Kept points lie on distinct pixels: the pieces write disjoint entries.
  split_evenly(pixel_voxel_.size(), kMinPreprocessPointsPerPiece);
  pool_.run(pieces_.size(), [this](std::size_t p) {
    std::fill(pixel_voxel_.begin() + static_cast<std::ptrdiff_t>(pieces_[p].begin),
              pixel_voxel_.begin() + static_cast<std::ptrdiff_t>(pieces_[p].end), -1);
  });
  split_evenly(kept_pixels.size(), kMinPreprocessPointsPerPiece);
  pool_.run(pieces_.size(), [this, &kept_pixels](std::size_t p) {
    const std::span<const int> voxel_of_point = voxels_.voxel_of_input();
    for (std::size_t i = pieces_[p].begin; i < pieces_[p].end; ++i) pixel_voxel_[kept_pixels[i]] = voxel_of_point[i];
  });

  scene_.plane = plane_;
  scene_.voxel_grid = VoxelGrid{.leaf = voxels_.leaf_size(), .corner = voxels_.grid_origin()};
  scene_.positions.assign(voxels_.positions().begin(), voxels_.positions().end());
  scene_.colors.assign(voxels_.colors().begin(), voxels_.colors().end());
  scene_.pixel_u.resize(voxel_count);
  scene_.pixel_v.resize(voxel_count);
  const std::span<const std::uint32_t> sources = voxels_.first_source_ids();
  const auto width = static_cast<std::uint32_t>(std::max(image_width_, 1));
  for (std::size_t k = 0; k < voxel_count; ++k) {
    scene_.pixel_u[k] = static_cast<std::int16_t>(sources[k] % width);
    scene_.pixel_v[k] = static_cast<std::int16_t>(sources[k] / width);
  }
  const auto t3 = Clock::now();

  cluster_voxels();
  keep_clusters_on_table();
  const auto t4 = Clock::now();

  stats_.backproject_ms = ms_between(t0, t1);
  stats_.plane_ms = ms_between(t1, t2);
  stats_.voxel_ms = ms_between(t2, t3);
  stats_.cluster_ms = ms_between(t3, t4);
  stats_.total_ms = ms_between(t0, t4);
  return scene_;
}

void Preprocessor::backproject_and_crop(const RgbdImageView& image) {
  const int w = image.width;
  const int h = image.height;
  if (w < 0 || h < 0 || w > kMaxImageSide || h > kMaxImageSide) {
    throw std::invalid_argument("Preprocessor::process: image size must be in [0, 32767] per side, got " +
                                std::to_string(w) + " x " + std::to_string(h));
  }
  const std::size_t pixels = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  if (image.depth_mm.size() != pixels || image.color.size() != pixels) {
    throw std::invalid_argument(
        "Preprocessor::process: depth and colour must both hold width * height = " + std::to_string(pixels) +
        " pixels, got " + std::to_string(image.depth_mm.size()) + " and " + std::to_string(image.color.size()));
  }
  const CameraIntrinsics& k = image.intrinsics;
  if (!(std::isfinite(k.fx) && std::isfinite(k.fy) && std::isfinite(k.cx) && std::isfinite(k.cy) && k.fx > 0.f &&
        k.fy > 0.f)) {
    throw std::invalid_argument("Preprocessor::process: intrinsics must be finite with fx, fy > 0");
  }

  if (w != ray_width_ || h != ray_height_ || k.fx != ray_intrinsics_.fx || k.fy != ray_intrinsics_.fy ||
      k.cx != ray_intrinsics_.cx || k.cy != ray_intrinsics_.cy) {
    ray_x_.resize(static_cast<std::size_t>(w));
    ray_y_.resize(static_cast<std::size_t>(h));
    for (int u = 0; u < w; ++u) ray_x_[static_cast<std::size_t>(u)] = (static_cast<float>(u) - k.cx) / k.fx;
    for (int v = 0; v < h; ++v) ray_y_[static_cast<std::size_t>(v)] = (static_cast<float>(v) - k.cy) / k.fy;
    ray_width_ = w;
    ray_height_ = h;
    ray_intrinsics_ = k;
  }
  image_width_ = w;
  if (cropped_positions_.size() < pixels) {
    cropped_positions_.resize(pixels);
    cropped_colors_.resize(pixels);
    cropped_pixels_.resize(pixels);
    above_positions_.resize(pixels);
    above_colors_.resize(pixels);
    above_pixels_.resize(pixels);
  }
  pixel_voxel_.resize(pixels);

  std::size_t valid = 0;
  std::size_t count = 0;
  split_evenly(static_cast<std::size_t>(h), kMinPreprocessRowsPerPiece);
  if (pieces_.size() <= 1) {
    crop_rows(image, 0, h, PointBuffers{cropped_positions_.data(), cropped_colors_.data(), cropped_pixels_.data()},
              valid, count);
  } else {
    // Each piece of rows writes its points to the (still unused) above-plane buffers from its
    // first pixel on, then copies them behind the previous pieces' points.
    pool_.run(pieces_.size(), [this, &image](std::size_t p) {
      Piece& piece = pieces_[p];
      const std::size_t at = piece.begin * static_cast<std::size_t>(image.width);
      crop_rows(image, static_cast<int>(piece.begin), static_cast<int>(piece.end),
                PointBuffers{above_positions_.data() + at, above_colors_.data() + at, above_pixels_.data() + at},
                piece.tally, piece.output_count);
    });
    for (Piece& piece : pieces_) {
      piece.first = count;
      count += piece.output_count;
      valid += piece.tally;
    }
    pool_.run(pieces_.size(), [this, &image](std::size_t p) {
      const Piece& piece = pieces_[p];
      const auto at = static_cast<std::ptrdiff_t>(piece.begin * static_cast<std::size_t>(image.width));
      const auto n = static_cast<std::ptrdiff_t>(piece.output_count);
      const auto first = static_cast<std::ptrdiff_t>(piece.first);
      std::copy(above_positions_.begin() + at, above_positions_.begin() + at + n, cropped_positions_.begin() + first);
      std::copy(above_colors_.begin() + at, above_colors_.begin() + at + n, cropped_colors_.begin() + first);
      std::copy(above_pixels_.begin() + at, above_pixels_.begin() + at + n, cropped_pixels_.begin() + first);
    });
  }
  cropped_count_ = count;
  stats_.valid_depth = valid;
  stats_.cropped = count;
}

void Preprocessor::split_evenly(std::size_t n, std::size_t min_piece) {
  // Several pieces per thread: a thread that wakes late (its core busy) still finds work, and the
  // caller is not left waiting for one large piece started late.
  const std::size_t most =
      pool_.threads() == 1 ? 1 : kPreprocessPiecesPerThread * static_cast<std::size_t>(pool_.threads());
  const std::size_t pieces = std::clamp<std::size_t>(n / min_piece, 1, most);
  pieces_.resize(pieces);
  for (std::size_t p = 0; p < pieces; ++p) {
    pieces_[p] = Piece{n * p / pieces, n * (p + 1) / pieces, 0, 0, 0};
  }
}

void Preprocessor::crop_rows(const RgbdImageView& image, int v_begin, int v_end, PointBuffers out,
                             std::size_t& valid_out, std::size_t& cropped_out) {
  const int w = image.width;
  const Eigen::Vector3f lo = options_.crop_min;
  const Eigen::Vector3f hi = options_.crop_max;
  const std::uint16_t* depth = image.depth_mm.data();
  const Rgb8* color = image.color.data();
  std::size_t valid = 0;
  std::size_t count = 0;
  for (int v = v_begin; v < v_end; ++v) {
    const float ry = ray_y_[static_cast<std::size_t>(v)];
    const std::size_t row = static_cast<std::size_t>(v) * static_cast<std::size_t>(w);
    for (int u = 0; u < w; ++u) {
      const std::size_t index = row + static_cast<std::size_t>(u);
      const std::uint16_t d = depth[index];
      if (d == 0) continue;
      ++valid;
      const float z = static_cast<float>(d) * kMetresPerMillimetre;
      const float x = ray_x_[static_cast<std::size_t>(u)] * z;
      const float y = ry * z;
      if (z < lo.z() || z > hi.z() || x < lo.x() || x > hi.x() || y < lo.y() || y > hi.y()) continue;
      out.positions[count] = Eigen::Vector3f(x, y, z);
      out.colors[count] = color[index];
      out.pixels[count] = static_cast<std::uint32_t>(index);
      ++count;
    }
  }
  valid_out = valid;
  cropped_out = count;
}

template <bool kWrite>
void Preprocessor::split_points(const TablePlane& plane, std::size_t begin, std::size_t end, std::size_t first,
                                std::size_t& inliers_out, std::size_t& kept_out) {
  const Eigen::Vector3f normal = plane.coefficients.head<3>();
  const float offset = plane.coefficients[3];
  const float band = options_.plane_fit.inlier_distance;
  const float margin = options_.plane_margin;
  const float sigmas = options_.plane_margin_sigmas;
  const Eigen::Vector3f& noise = options_.depth_sigma;
  std::size_t inliers = 0;
  std::size_t kept = 0;
  for (std::size_t i = begin; i < end; ++i) {
    const Eigen::Vector3f& p = cropped_positions_[i];
    const float distance = normal.dot(p) + offset;
    inliers += std::abs(distance) < band ? 1 : 0;
    const float from_reference = p.z() - noise[2];
    const float noise_margin = sigmas * (noise[0] + noise[1] * from_reference * from_reference);
    if (distance > std::max(margin, noise_margin)) {
      if constexpr (kWrite) {
        above_positions_[first + kept] = p;
        above_colors_[first + kept] = cropped_colors_[i];
        above_pixels_[first + kept] = cropped_pixels_[i];
      }
      ++kept;
    }
  }
  inliers_out = inliers;
  kept_out = kept;
}

float Preprocessor::split_by_plane(const TablePlane& plane) {
  std::size_t inliers = 0;
  std::size_t kept = 0;
  split_evenly(cropped_count_, kMinPreprocessPointsPerPiece);
  if (pieces_.size() <= 1) {
    split_points<true>(plane, 0, cropped_count_, 0, inliers, kept);
  } else {
    pool_.run(pieces_.size(), [this, &plane](std::size_t p) {
      Piece& piece = pieces_[p];
      split_points<false>(plane, piece.begin, piece.end, 0, piece.tally, piece.output_count);
    });
    for (Piece& piece : pieces_) {
      piece.first = kept;
      kept += piece.output_count;
      inliers += piece.tally;
    }
    pool_.run(pieces_.size(), [this, &plane](std::size_t p) {
      Piece& piece = pieces_[p];
      std::size_t unused_inliers = 0, unused_kept = 0;
      split_points<true>(plane, piece.begin, piece.end, piece.first, unused_inliers, unused_kept);
    });
  }
  above_count_ = kept;
  return cropped_count_ == 0 ? 0.f : static_cast<float>(inliers) / static_cast<float>(cropped_count_);
}

void Preprocessor::remove_table() {
  kept_all_cropped_ = false;
  above_count_ = 0;
  if (!options_.remove_plane) {
    kept_all_cropped_ = true;
    return;
  }
  if (cropped_count_ == 0) return;  // nothing seen: keep the plane as it is

  if (plane_.valid) {
    const float share = split_by_plane(plane_);
    if (share >= options_.plane_keep_ratio * plane_fitted_share_) {
      stats_.plane_inlier_share = share;
      return;
    }
  }

  stats_.plane_refitted = true;
  float share = 0.f;
  const TablePlane fitted =
      plane_fitter_.fit(std::span<const Eigen::Vector3f>(cropped_positions_.data(), cropped_count_), &share);
  if (!fitted.valid) {
    // No dominant plane in view: nothing is removed, and the next frame tries again.
    reset_plane();
    kept_all_cropped_ = true;
    return;
  }
  plane_ = fitted;
  plane_fitted_share_ = share;
  stats_.plane_inlier_share = split_by_plane(plane_);
}

int Preprocessor::voxel_index_of(const Eigen::Vector3f& p) const { return voxels_.voxel_index_of(p); }

int Preprocessor::voxel_index_at(int u, int v) const {
  if (u < 0 || v < 0 || u >= image_width_ || image_width_ == 0) return -1;
  const std::size_t index =
      static_cast<std::size_t>(v) * static_cast<std::size_t>(image_width_) + static_cast<std::size_t>(u);
  return index < pixel_voxel_.size() ? pixel_voxel_[index] : -1;
}

}  // namespace mfot
