#include "mfot/service/run_writer.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <stdexcept>
#include <vector>

#include "mfot/service/frame_codec.hpp"
#include "mfot/service/service_main.hpp"

namespace mfot::service {

namespace {
std::ofstream open_csv(const std::string& path, const char* header, bool append) {
  std::error_code ec;
  const bool continued = append && std::filesystem::file_size(path, ec) > 0 && !ec;
  errno = 0;
  std::ofstream out(path, std::ios::out | (continued ? std::ios::app : std::ios::trunc));
  if (!out) throw OutputError(path + ": cannot create: " + (errno != 0 ? std::strerror(errno) : "unknown error"));
  if (!continued) out << header << '\n';
  return out;
}

// A stream that failed lost bytes on their way to `path`: an error naming it and the system's reason
// (errno of the failed write, e.g. "No space left on device").
void check_stream(const std::ofstream& out, const std::string& path, int saved_errno) {
  if (out.good()) return;
  throw OutputError(path + ": cannot write: " + (saved_errno != 0 ? std::strerror(saved_errno) : "stream error"));
}

// A voxel's cell index on one axis, offset so that cells within 2^20 voxels of the origin are
// non-negative and fit 21 bits.
std::int64_t cell_of(float v, float inv) { return static_cast<std::int64_t>(std::floor(v * inv)) + (1 << 20); }

std::uint64_t voxel_key(std::int64_t cx, std::int64_t cy, std::int64_t cz) {
  return (static_cast<std::uint64_t>(cx) << 42) | (static_cast<std::uint64_t>(cy) << 21) |
         static_cast<std::uint64_t>(cz);
}

// Scene voxel labels by voxel key: open addressing with linear probing, the first scene point
// of a voxel wins. It is built once per frame for ~10^4 voxels and looked up once per measured
// pixel (~3 x 10^5 times), where std::unordered_map's node chasing cost 5 ms a frame.
class VoxelLabels {
 public:
  explicit VoxelLabels(std::size_t voxels) {
    std::size_t slots = 16;
    while (slots < 2 * voxels) slots *= 2;
    keys_.assign(slots, kEmpty);
    labels_.assign(slots, 0);
    mask_ = slots - 1;
  }
  void insert(std::uint64_t key, std::int32_t label) {
    std::size_t i = slot_of(key);
    while (keys_[i] != kEmpty && keys_[i] != key) i = (i + 1) & mask_;
    if (keys_[i] == key) return;
    keys_[i] = key;
    labels_[i] = label;
  }
  // The label of `key`'s voxel, or -1 when no scene point lies in it.
  std::int32_t find(std::uint64_t key) const {
    for (std::size_t i = slot_of(key);; i = (i + 1) & mask_) {
      if (keys_[i] == key) return labels_[i];
      if (keys_[i] == kEmpty) return -1;
    }
  }

 private:
  // No key of a cell within 5 km of the camera (21 bits per axis) has every bit set.
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  std::size_t slot_of(std::uint64_t key) const {
    return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> 32) & mask_;
  }
  std::vector<std::uint64_t> keys_;
  std::vector<std::int32_t> labels_;
  std::size_t mask_ = 0;
};
}  // namespace

RunWriter::RunWriter(const std::string& dir, bool append) : dir_(dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir_ + "/labels", ec);
  if (ec) throw OutputError(dir_ + ": cannot create run directory: " + ec.message());
  poses_ = open_csv(dir_ + "/poses.csv", "frame,utime,object_id,x,y,z,qx,qy,qz,qw,confidence,stale", append);
  fitting_ = open_csv(dir_ + "/fitting.csv", "frame,object_id,fitting_distance_m", append);
}

void RunWriter::write_pose(std::int64_t frame, std::int64_t utime, std::int32_t object_id, const Pose& pose,
                           float confidence, bool stale) {
  char line[512];
  std::snprintf(line, sizeof line, "%lld,%lld,%d,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.6g,%d\n",
                static_cast<long long>(frame), static_cast<long long>(utime), object_id, pose.translation.x(),
                pose.translation.y(), pose.translation.z(), pose.rotation.x(), pose.rotation.y(), pose.rotation.z(),
                pose.rotation.w(), confidence, stale ? 1 : 0);
  poses_ << line;
}

void RunWriter::write_fitting(std::int64_t frame, std::int32_t object_id, double fitting_distance_m) {
  fitting_ << frame << ',' << object_id << ',' << fitting_distance_m << '\n';
}

void RunWriter::write_labels(std::int64_t frame, const Image16& labels) { write_label_image(dir_, frame, labels); }

void write_label_image(const std::string& run_dir, std::int64_t frame, const Image16& labels) {
  char name[64];
  std::snprintf(name, sizeof name, "/labels/%06lld.png", static_cast<long long>(frame));
  const std::string path = run_dir + name;
  try {
    write_png16(path + ".tmp", labels, PngCompression::kFast);  // one per frame
  } catch (const ImageIoError& e) {
    throw OutputError(e.what());
  }
  std::error_code error;
  std::filesystem::rename(path + ".tmp", path, error);
  if (error) throw OutputError(path + ": cannot rename from " + path + ".tmp: " + error.message());
}

void RunWriter::flush_poses() {
  errno = 0;
  poses_.flush();
  check_stream(poses_, dir_ + "/poses.csv", errno);
}

void RunWriter::flush_fitting() {
  errno = 0;
  fitting_.flush();
  check_stream(fitting_, dir_ + "/fitting.csv", errno);
}

void RunWriter::flush() {
  flush_poses();
  flush_fitting();
}

Image16 dense_labels(int width, int height, float fx, float fy, float cx, float cy,
                     std::span<const std::uint16_t> depth_mm, const VoxelGrid& voxel_grid,
                     std::span<const Eigen::Vector3f> scene_points, std::span<const std::int32_t> labels) {
  if (width <= 0 || height <= 0 || depth_mm.size() != static_cast<std::size_t>(width) * height) {
    throw std::invalid_argument("dense_labels: depth image size does not match width x height");
  }
  if (scene_points.size() != labels.size()) throw std::invalid_argument("dense_labels: one label per scene point");
  if (!(voxel_grid.leaf > 0.f)) throw std::invalid_argument("dense_labels: voxel_size must be > 0");
  if (!voxel_grid.corner.allFinite()) throw std::invalid_argument("dense_labels: voxel_origin must be finite");
  Image16 out;
  out.width = width;
  out.height = height;
  out.pixels.assign(depth_mm.size(), 0);
  const float inv = 1.f / voxel_grid.leaf;
  const Eigen::Vector3f& corner = voxel_grid.corner;
  // Pixels whose cell lies outside the scene's cell box are no scene point without a lookup.
  std::array<std::int64_t, 3> lo{std::numeric_limits<std::int64_t>::max(), std::numeric_limits<std::int64_t>::max(),
                                 std::numeric_limits<std::int64_t>::max()};
  std::array<std::int64_t, 3> hi{std::numeric_limits<std::int64_t>::min(), std::numeric_limits<std::int64_t>::min(),
                                 std::numeric_limits<std::int64_t>::min()};
  VoxelLabels label_of_voxel(scene_points.size());
  for (std::size_t k = 0; k < scene_points.size(); ++k) {
    const Eigen::Vector3f p = scene_points[k] - corner;
    const std::array<std::int64_t, 3> c{cell_of(p.x(), inv), cell_of(p.y(), inv), cell_of(p.z(), inv)};
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], c[a]);
      hi[a] = std::max(hi[a], c[a]);
    }
    label_of_voxel.insert(voxel_key(c[0], c[1], c[2]), std::max(labels[k], 0));
  }
  std::vector<float> ray_x(static_cast<std::size_t>(width));
  for (int u = 0; u < width; ++u) ray_x[static_cast<std::size_t>(u)] = (static_cast<float>(u) - cx) / fx;
  for (int v = 0; v < height; ++v) {
    const float ry = (static_cast<float>(v) - cy) / fy;
    for (int u = 0; u < width; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * width + u;
      if (depth_mm[i] == 0) continue;
      const float z = static_cast<float>(depth_mm[i]) * 0.001f;
      const std::int64_t kz = cell_of(z - corner.z(), inv);
      const std::int64_t ky = cell_of(ry * z - corner.y(), inv);
      const std::int64_t kx = cell_of(ray_x[static_cast<std::size_t>(u)] * z - corner.x(), inv);
      std::int32_t label = -1;
      if (kz >= lo[2] && kz <= hi[2] && ky >= lo[1] && ky <= hi[1] && kx >= lo[0] && kx <= hi[0]) {
        label = label_of_voxel.find(voxel_key(kx, ky, kz));
      }
      out.pixels[i] = label < 0 ? kNotScenePoint : static_cast<std::uint16_t>(std::min(label, kNotScenePoint - 1));
    }
  }
  return out;
}

Image16 frame_label_image(const frame_t& frame, const VoxelGrid& voxel_grid,
                          std::span<const Eigen::Vector3f> scene_points, std::span<const std::int32_t> labels) {
  const Frame f = decode_frame(frame, FrameParts::kDepthOnly);
  return dense_labels(f.width, f.height, f.fx, f.fy, f.cx, f.cy, f.depth_mm, voxel_grid, scene_points, labels);
}

}  // namespace mfot::service
