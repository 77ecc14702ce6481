#include "mfot/capture/pcd_source.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <cmath>

#include "../pcd/pcd_image.hpp"

namespace mfot::capture {

namespace fs = std::filesystem;

bool natural_less(const std::string& a, const std::string& b) {
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (std::isdigit(static_cast<unsigned char>(a[i])) && std::isdigit(static_cast<unsigned char>(b[j]))) {
      std::size_t i_end = i, j_end = j;
      while (i_end < a.size() && std::isdigit(static_cast<unsigned char>(a[i_end]))) ++i_end;
      while (j_end < b.size() && std::isdigit(static_cast<unsigned char>(b[j_end]))) ++j_end;
      // Compare the numbers by value: without leading zeros, a longer run is larger.
      std::string x = a.substr(i, i_end - i), y = b.substr(j, j_end - j);
      x.erase(0, std::min(x.find_first_not_of('0'), x.size() - 1));
      y.erase(0, std::min(y.find_first_not_of('0'), y.size() - 1));
      if (x.size() != y.size()) return x.size() < y.size();
      if (x != y) return x < y;
      i = i_end;
      j = j_end;
      continue;
    }
    if (a[i] != b[j]) return a[i] < b[j];
    ++i;
    ++j;
  }
  return a.size() - i < b.size() - j;
}

namespace {
// Least squares of pixel = focal * ratio + centre over the measured points (ratio = x/z or y/z).
struct AxisFit {
  double n = 0, sr = 0, sp = 0, srr = 0, srp = 0;
  void add(double ratio, double pixel) {
    n += 1;
    sr += ratio;
    sp += pixel;
    srr += ratio * ratio;
    srp += ratio * pixel;
  }
  bool solve(float& focal, float& centre) const {
    const double var = n * srr - sr * sr;
    if (n < 3 || !(std::abs(var) > 1e-12 * n * n)) return false;
    focal = static_cast<float>((n * srp - sr * sp) / var);
    centre = static_cast<float>((sp - static_cast<double>(focal) * sr) / n);
    return std::isfinite(focal) && focal > 0.f && std::isfinite(centre);
  }
};
}  // namespace

service::Frame frame_from_organised_cloud(const PcdImage& image) {
  service::Frame frame;
  frame.width = image.width;
  frame.height = image.height;
  const std::size_t n = static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height);
  frame.depth_mm.assign(n, 0);
  frame.color.resize(n);
  AxisFit fit_u, fit_v;
  for (std::size_t i = 0; i < n; ++i) {
    frame.color[i] = Rgb8{image.rgb[3 * i], image.rgb[3 * i + 1], image.rgb[3 * i + 2]};
    const float x = image.xyz[3 * i], y = image.xyz[3 * i + 1], z = image.xyz[3 * i + 2];
    if (!(std::isfinite(x) && std::isfinite(y) && std::isfinite(z) && z > 0.f && z < 65.535f)) continue;
    frame.depth_mm[i] = static_cast<std::uint16_t>(std::lround(z * 1000.f));
    if (frame.depth_mm[i] == 0) continue;
    const auto u = static_cast<double>(i % static_cast<std::size_t>(image.width));
    const auto v = static_cast<double>(i / static_cast<std::size_t>(image.width));
    fit_u.add(x / z, u);
    fit_v.add(y / z, v);
  }
  if (!fit_u.solve(frame.fx, frame.cx) || !fit_v.solve(frame.fy, frame.cy)) {
    throw CaptureError("no measured points to fit the camera intrinsics to (" +
                       std::to_string(static_cast<long long>(fit_u.n)) + " finite points)");
  }
  return frame;
}

service::GroundTruthFrame labels_as_truth(const PcdImage& image, std::int64_t index, std::int64_t utime,
                                          std::uint32_t background_label_max) {
  service::GroundTruthFrame truth;
  truth.frame = index;
  truth.utime = utime;
  truth.labels.width = image.width;
  truth.labels.height = image.height;
  truth.labels.pixels.reserve(image.label.size());
  // Label images are 16-bit and 65535 marks measured pixels that are not scene points.
  for (const std::uint32_t label : image.label) {
    truth.labels.pixels.push_back(
        label <= background_label_max ? 0 : static_cast<std::uint16_t>(std::min<std::uint32_t>(label, 65534)));
  }
  return truth;
}

PcdFolderSource::PcdFolderSource(const std::string& folder, double frame_period_s, std::uint32_t background_label_max)
    : folder_(folder), frame_period_s_(frame_period_s), background_label_max_(background_label_max) {
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) throw CaptureError(folder + ": not a folder of PCD files");
  for (const auto& entry : fs::directory_iterator(folder, ec)) {
    if (entry.is_regular_file() && entry.path().extension() == ".pcd") files_.push_back(entry.path());
  }
  if (ec) throw CaptureError(folder + ": cannot list the folder (" + ec.message() + ")");
  if (files_.empty()) throw CaptureError(folder + ": no .pcd files");
  std::sort(files_.begin(), files_.end(), [](const fs::path& a, const fs::path& b) {
    return natural_less(a.filename().string(), b.filename().string());
  });
}

std::optional<SourceFrame> PcdFolderSource::next() {
  while (next_file_ < files_.size()) {
    const fs::path& path = files_[next_file_++];
    PcdImage image;
    std::string error;
    try {
      if (read_organised_pcd(path.string(), image, error)) {
        SourceFrame item;
        item.frame = frame_from_organised_cloud(image);
        item.index = index_;
        item.frame.capture_utime =
            static_cast<std::int64_t>(std::llround(1e6 * frame_period_s_ * static_cast<double>(index_)));
        if (!image.label.empty()) {
          item.truth = labels_as_truth(image, item.index, item.frame.capture_utime, background_label_max_);
        }
        ++index_;
        return item;
      }
    } catch (const CaptureError& e) {
      error = e.what();
    }
    ++skipped_;
    spdlog::error("{}: skipped: {} ({} files skipped so far)", path.string(), error, skipped_);
  }
  return std::nullopt;
}

bool PcdFolderSource::rewind() {
  next_file_ = 0;
  index_ = 0;
  return true;
}

}  // namespace mfot::capture
