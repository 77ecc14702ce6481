#include "pcd_image.hpp"

#include <pcl/PCLPointCloud2.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <algorithm>

namespace mfot::capture {

namespace {
bool has_field(const pcl::PCLPointCloud2& cloud, const std::string& name) {
  return std::any_of(cloud.fields.begin(), cloud.fields.end(),
                     [&](const pcl::PCLPointField& f) { return f.name == name; });
}
}  // namespace

bool read_organised_pcd(const std::string& path, PcdImage& out, std::string& error) {
  pcl::PCLPointCloud2 blob;
  pcl::PCDReader reader;
  try {
    // The header first: PCL's reader crashes on a body after a header without fields or points.
    Eigen::Vector4f origin;
    Eigen::Quaternionf orientation;
    int version = 0, data_type = 0;
    unsigned int data_index = 0;
    if (reader.readHeader(path, blob, origin, orientation, version, data_type, data_index) < 0 || blob.fields.empty() ||
        blob.width == 0 || blob.height == 0) {
      error = "not a PCD file (no header with fields and points)";
      return false;
    }
    if (reader.read(path, blob) < 0) {
      error = "not a readable PCD file (missing, truncated or malformed)";
      return false;
    }
  } catch (const std::exception& e) {
    error = std::string("not a readable PCD file: ") + e.what();
    return false;
  }
  if (blob.height <= 1) {
    error = "not organised (height " + std::to_string(blob.height) + "): an RGB-D frame needs rows and columns";
    return false;
  }
  if (!has_field(blob, "x") || !has_field(blob, "y") || !has_field(blob, "z")) {
    error = "no x y z fields";
    return false;
  }
  if (!has_field(blob, "rgb") && !has_field(blob, "rgba")) {
    error = "no rgb or rgba field";
    return false;
  }
  pcl::PointCloud<pcl::PointXYZRGBA> cloud;
  pcl::fromPCLPointCloud2(blob, cloud);
  out.width = static_cast<int>(cloud.width);
  out.height = static_cast<int>(cloud.height);
  out.xyz.resize(3 * cloud.size());
  out.rgb.resize(3 * cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const pcl::PointXYZRGBA& p = cloud[i];
    out.xyz[3 * i] = p.x;
    out.xyz[3 * i + 1] = p.y;
    out.xyz[3 * i + 2] = p.z;
    out.rgb[3 * i] = p.r;
    out.rgb[3 * i + 1] = p.g;
    out.rgb[3 * i + 2] = p.b;
  }
  out.label.clear();
  if (has_field(blob, "label")) {
    pcl::PointCloud<pcl::Label> labels;
    pcl::fromPCLPointCloud2(blob, labels);
    for (const pcl::Label& l : labels) out.label.push_back(l.label);
  }
  return true;
}

}  // namespace mfot::capture
