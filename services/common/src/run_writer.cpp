#include "mfot/service/run_writer.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <unordered_map>

namespace mfot::service {

namespace {
std::ofstream open_csv(const std::string& path, const char* header, bool append) {
  std::error_code ec;
  const bool continued = append && std::filesystem::file_size(path, ec) > 0 && !ec;
  std::ofstream out(path, std::ios::out | (continued ? std::ios::app : std::ios::trunc));
  if (!out) throw std::runtime_error(path + ": cannot create file");
  if (!continued) out << header << '\n';
  return out;
}

std::uint64_t voxel_key(const Eigen::Vector3f& p, float inv) {
  const auto cell = [inv](float v) { return static_cast<std::int64_t>(std::floor(v * inv)) + (1 << 20); };
  return (static_cast<std::uint64_t>(cell(p.x())) << 42) | (static_cast<std::uint64_t>(cell(p.y())) << 21) |
         static_cast<std::uint64_t>(cell(p.z()));
}
}  // namespace

RunWriter::RunWriter(const std::string& dir, bool append) : dir_(dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir_ + "/labels", ec);
  if (ec) throw std::runtime_error(dir_ + ": cannot create run directory: " + ec.message());
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

void RunWriter::write_labels(std::int64_t frame, const Image16& labels) {
  char name[64];
  std::snprintf(name, sizeof name, "/labels/%06lld.png", static_cast<long long>(frame));
  const std::string path = dir_ + name;
  write_png16(path + ".tmp", labels);
  std::filesystem::rename(path + ".tmp", path);
}

void RunWriter::flush() {
  poses_.flush();
  fitting_.flush();
}

Image16 dense_labels(int width, int height, float fx, float fy, float cx, float cy,
                     std::span<const std::uint16_t> depth_mm, float voxel_size,
                     std::span<const Eigen::Vector3f> scene_points, std::span<const std::int32_t> labels) {
  if (width <= 0 || height <= 0 || depth_mm.size() != static_cast<std::size_t>(width) * height) {
    throw std::invalid_argument("dense_labels: depth image size does not match width x height");
  }
  if (scene_points.size() != labels.size()) throw std::invalid_argument("dense_labels: one label per scene point");
  if (!(voxel_size > 0.f)) throw std::invalid_argument("dense_labels: voxel_size must be > 0");
  Image16 out;
  out.width = width;
  out.height = height;
  out.pixels.assign(depth_mm.size(), 0);
  const float inv = 1.f / voxel_size;
  std::unordered_map<std::uint64_t, std::int32_t> label_of_voxel;
  label_of_voxel.reserve(scene_points.size() * 2);
  for (std::size_t k = 0; k < scene_points.size(); ++k) {
    label_of_voxel.emplace(voxel_key(scene_points[k], inv), std::max(labels[k], 0));
  }
  for (int v = 0; v < height; ++v) {
    const float ry = (static_cast<float>(v) - cy) / fy;
    for (int u = 0; u < width; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * width + u;
      if (depth_mm[i] == 0) continue;
      const float z = static_cast<float>(depth_mm[i]) * 0.001f;
      const Eigen::Vector3f p((static_cast<float>(u) - cx) / fx * z, ry * z, z);
      const auto it = label_of_voxel.find(voxel_key(p, inv));
      out.pixels[i] = it == label_of_voxel.end()
                          ? kNotScenePoint
                          : static_cast<std::uint16_t>(std::min(it->second, kNotScenePoint - 1));
    }
  }
  return out;
}

}  // namespace mfot::service
