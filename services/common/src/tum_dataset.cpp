#include "mfot/service/tum_dataset.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cinttypes>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>
#include <tuple>

namespace mfot::service {
namespace fs = std::filesystem;
namespace {

struct ListLine {
  double time_s;
  std::string path;
};

bool parse_double(const std::string& text, double& out) {
  const char* begin = text.data();
  const char* end = begin + text.size();
  const auto result = std::from_chars(begin, end, out);
  return result.ec == std::errc() && result.ptr == end && std::isfinite(out);
}

bool parse_int64(const std::string& text, std::int64_t& out) {
  const char* begin = text.data();
  const char* end = begin + text.size();
  const auto result = std::from_chars(begin, end, out);
  return result.ec == std::errc() && result.ptr == end;
}

std::vector<std::string> split_whitespace(const std::string& line) {
  std::vector<std::string> tokens;
  std::istringstream stream(line);
  std::string token;
  while (stream >> token) tokens.push_back(token);
  return tokens;
}

std::string trim(const std::string& text) {
  const auto first = text.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) return "";
  const auto last = text.find_last_not_of(" \t\r\n");
  return text.substr(first, last - first + 1);
}

// Seconds with exactly six decimals from integer microseconds, so names round-trip exactly.
std::string timestamp_text(std::int64_t utime) {
  char text[40];
  std::snprintf(text, sizeof text, "%" PRId64 ".%06" PRId64, utime / 1000000, utime % 1000000);
  return text;
}

void create_folder(const std::string& folder) {
  std::error_code error;
  fs::create_directories(folder, error);
  if (error) throw DatasetError(folder + ": cannot create folder: " + error.message());
}

std::FILE* open_for_append(const std::string& path, const char* header) {
  std::FILE* file = std::fopen(path.c_str(), "w");
  if (file == nullptr) throw DatasetError(path + ": cannot create: " + std::strerror(errno));
  if (std::fputs(header, file) < 0 || std::fflush(file) != 0) {
    std::fclose(file);
    throw DatasetError(path + ": cannot write: " + std::strerror(errno));
  }
  return file;
}

// One write call per frame keeps a frame's lines together even if the process dies.
void append(std::FILE* file, const std::string& path, const std::string& text) {
  if (std::fwrite(text.data(), 1, text.size(), file) != text.size() || std::fflush(file) != 0) {
    throw DatasetError(path + ": cannot append: " + std::strerror(errno));
  }
}

void rename_into_place(const std::string& temporary, const std::string& path) {
  std::error_code error;
  fs::rename(temporary, path, error);
  if (error) {
    fs::remove(temporary, error);
    throw DatasetError(path + ": cannot rename from temporary file: " + error.message());
  }
}

void write_png16_atomically(const std::string& path, const Image16& image,
                            PngCompression compression = PngCompression::kSmall) {
  const std::string temporary = path + ".tmp";
  try {
    write_png16(temporary, image, compression);
  } catch (const ImageIoError& e) {
    throw DatasetError(e.what());
  }
  rename_into_place(temporary, path);
}

void write_png_rgb_atomically(const std::string& path, const ImageRgb& image) {
  const std::string temporary = path + ".tmp";
  try {
    write_png_rgb(temporary, image);
  } catch (const ImageIoError& e) {
    throw DatasetError(e.what());
  }
  rename_into_place(temporary, path);
}

void close_file(std::FILE*& file) {
  if (file != nullptr) std::fclose(file);
  file = nullptr;
}

std::array<float, 4> read_intrinsics(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw DatasetError(path + ": cannot open");
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    const std::string text = trim(line);
    if (text.empty() || text[0] == '#') continue;
    const auto tokens = split_whitespace(text);
    std::array<float, 4> values{};
    bool ok = tokens.size() == 4;
    for (std::size_t i = 0; ok && i < 4; ++i) {
      double value = 0.0;
      ok = parse_double(tokens[i], value);
      values[i] = static_cast<float>(value);
      ok = ok && std::isfinite(values[i]);  // a finite double such as 1e300 is still infinite as a float
    }
    if (!ok || !(values[0] > 0.0f && values[1] > 0.0f)) {
      throw DatasetError(path + ":" + std::to_string(number) + ": expected 'fx fy cx cy' with positive focal lengths");
    }
    return values;
  }
  throw DatasetError(path + ": no 'fx fy cx cy' line");
}

}  // namespace

// ---- association -------------------------------------------------------------------------------

std::vector<std::pair<std::size_t, std::size_t>> associate_by_time(const std::vector<double>& rgb_times,
                                                                   const std::vector<double>& depth_times,
                                                                   double max_difference) {
  std::vector<std::size_t> depth_order(depth_times.size());
  for (std::size_t j = 0; j < depth_order.size(); ++j) depth_order[j] = j;
  std::sort(depth_order.begin(), depth_order.end(),
            [&](std::size_t a, std::size_t b) { return std::tie(depth_times[a], a) < std::tie(depth_times[b], b); });
  std::vector<double> sorted_depth(depth_order.size());
  for (std::size_t k = 0; k < depth_order.size(); ++k) sorted_depth[k] = depth_times[depth_order[k]];

  std::vector<std::tuple<double, std::size_t, std::size_t>> candidates;  // (|dt|, rgb, depth)
  for (std::size_t i = 0; i < rgb_times.size(); ++i) {
    const auto first = std::lower_bound(sorted_depth.begin(), sorted_depth.end(), rgb_times[i] - max_difference);
    for (auto it = first; it != sorted_depth.end() && *it <= rgb_times[i] + max_difference; ++it) {
      const std::size_t j = depth_order[static_cast<std::size_t>(it - sorted_depth.begin())];
      candidates.emplace_back(std::abs(rgb_times[i] - depth_times[j]), i, j);
    }
  }
  std::sort(candidates.begin(), candidates.end());
  std::vector<bool> rgb_used(rgb_times.size(), false), depth_used(depth_times.size(), false);
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (const auto& [difference, i, j] : candidates) {
    if (rgb_used[i] || depth_used[j]) continue;
    rgb_used[i] = depth_used[j] = true;
    pairs.emplace_back(i, j);
  }
  std::sort(pairs.begin(), pairs.end(), [&](const auto& a, const auto& b) {
    return std::tie(rgb_times[a.first], a.first) < std::tie(rgb_times[b.first], b.first);
  });
  return pairs;
}

// ---- reader ------------------------------------------------------------------------------------

void TumReaderOptions::validate() const {
  if (folder.empty()) throw std::invalid_argument("TumReaderOptions.folder must not be empty");
  if (!(depth_scale > 0.0 && std::isfinite(depth_scale))) {
    throw std::invalid_argument("TumReaderOptions.depth_scale must be finite and > 0 (units per metre)");
  }
  if (!(max_time_difference_s > 0.0 && std::isfinite(max_time_difference_s))) {
    throw std::invalid_argument("TumReaderOptions.max_time_difference_s must be finite and > 0");
  }
  if (intrinsics && !((*intrinsics)[0] > 0.0f && (*intrinsics)[1] > 0.0f)) {
    throw std::invalid_argument("TumReaderOptions.intrinsics: fx and fy must be > 0");
  }
}

TumDatasetReader::TumDatasetReader(TumReaderOptions options) : options_(std::move(options)) {
  options_.validate();
  const std::string& folder = options_.folder;
  std::error_code error;
  if (!fs::is_directory(folder, error)) throw DatasetError(folder + ": no such folder");

  const auto read_list = [&](const std::string& name) {
    const std::string path = (fs::path(folder) / name).string();
    std::ifstream in(path);
    if (!in) throw DatasetError(path + ": missing or unreadable (not a TUM RGB-D folder?)");
    std::vector<ListLine> lines;
    std::string line;
    int number = 0;
    while (std::getline(in, line)) {
      ++number;
      const std::string text = trim(line);
      if (text.empty() || text[0] == '#') continue;
      const auto tokens = split_whitespace(text);
      double time_s = 0.0;
      if (tokens.size() != 2 || !parse_double(tokens[0], time_s) || time_s < 0.0) {
        warn(path + ":" + std::to_string(number) + ": expected '<timestamp> <file>', line skipped");
        continue;
      }
      lines.push_back({time_s, (fs::path(folder) / tokens[1]).string()});
    }
    if (lines.empty()) throw DatasetError(path + ": lists no images");
    return lines;
  };
  const auto rgb = read_list("rgb.txt");
  const auto depth = read_list("depth.txt");

  if (const auto path = (fs::path(folder) / "intrinsics.txt").string(); fs::exists(path, error)) {
    intrinsics_ = read_intrinsics(path);  // the folder's own calibration wins
  } else if (options_.intrinsics) {
    intrinsics_ = *options_.intrinsics;
  } else {
    intrinsics_ = {kTumDefaultFx, kTumDefaultFy, kTumDefaultCx, kTumDefaultCy};
  }

  std::vector<double> rgb_times, depth_times;
  for (const auto& l : rgb) rgb_times.push_back(l.time_s);
  for (const auto& l : depth) depth_times.push_back(l.time_s);
  for (const auto& [i, j] : associate_by_time(rgb_times, depth_times, options_.max_time_difference_s)) {
    entries_.push_back({rgb[i].time_s, depth[j].time_s, rgb[i].path, depth[j].path});
  }
  if (entries_.empty()) {
    throw DatasetError(folder + ": no rgb/depth pair within " + std::to_string(options_.max_time_difference_s) + " s");
  }
  if (entries_.size() < rgb.size()) {
    warn(folder + ": " + std::to_string(rgb.size() - entries_.size()) + " of " + std::to_string(rgb.size()) +
         " colour images have no depth image within " + std::to_string(options_.max_time_difference_s) + " s");
  }
}

void TumDatasetReader::warn(std::string message) {
  spdlog::warn("{}", message);
  warnings_.push_back(std::move(message));
}

std::optional<Frame> TumDatasetReader::read(std::size_t index) {
  const TumEntry& e = entries_.at(index);
  ImageRgb rgb;
  Image16 depth;
  try {
    rgb = read_png_rgb(e.rgb_path);
    depth = read_png16(e.depth_path);
  } catch (const ImageIoError& error) {
    warn(std::string(error.what()) + "; frame skipped");
    return std::nullopt;
  }
  if (depth.width != rgb.width || depth.height != rgb.height) {
    warn(e.depth_path + ": depth is " + std::to_string(depth.width) + "x" + std::to_string(depth.height) +
         " but colour " + e.rgb_path + " is " + std::to_string(rgb.width) + "x" + std::to_string(rgb.height) +
         "; frame skipped");
    return std::nullopt;
  }
  if (rgb.width > kMaxFrameSide || rgb.height > kMaxFrameSide) {
    warn(e.rgb_path + ": image larger than " + std::to_string(kMaxFrameSide) + " pixels a side; frame skipped");
    return std::nullopt;
  }
  Frame frame;
  frame.capture_utime = std::llround(e.rgb_time_s * 1e6);
  frame.width = rgb.width;
  frame.height = rgb.height;
  frame.fx = intrinsics_[0];
  frame.fy = intrinsics_[1];
  frame.cx = intrinsics_[2];
  frame.cy = intrinsics_[3];
  frame.color = std::move(rgb.pixels);
  frame.depth_mm.resize(depth.pixels.size());
  const double to_mm = 1000.0 / options_.depth_scale;
  for (std::size_t i = 0; i < depth.pixels.size(); ++i) {
    const long long mm = std::llround(depth.pixels[i] * to_mm);
    frame.depth_mm[i] = mm > 65535 ? 0 : static_cast<std::uint16_t>(mm);
  }
  return frame;
}

// ---- ground truth ------------------------------------------------------------------------------

std::string label_file_name(std::int64_t frame) {
  char name[32];
  std::snprintf(name, sizeof name, "%06" PRId64 ".png", frame);
  return name;
}

GroundTruthWriter::GroundTruthWriter(std::string folder) : folder_(std::move(folder)) {
  create_folder((fs::path(folder_) / "labels").string());
  const std::string path = (fs::path(folder_) / "poses.csv").string();
  std::error_code error;
  if (fs::exists(path, error)) throw DatasetError(path + ": already exists; choose an empty ground-truth folder");
  poses_ = open_for_append(path, "frame,utime,object_id,is_hand,x,y,z,qx,qy,qz,qw,axis_x,axis_y,axis_z\n");
}

GroundTruthWriter::~GroundTruthWriter() { close_file(poses_); }

void GroundTruthWriter::write_scene(const std::string& yaml) {
  if (yaml.empty()) return;
  const std::string path = (fs::path(folder_) / "scene.yaml").string();
  std::ofstream out(path);
  out << yaml;
  if (!out) throw std::runtime_error(path + ": cannot write");
}

void GroundTruthWriter::write(const GroundTruthFrame& truth) {
  if (truth.frame < 0) throw DatasetError("ground truth frame index must be >= 0");
  if (!truth.labels.pixels.empty() || truth.labels.width != 0) {
    // Written every frame by the capture service: fast compression (see PngCompression).
    write_png16_atomically((fs::path(folder_) / "labels" / label_file_name(truth.frame)).string(), truth.labels,
                           PngCompression::kFast);
  }
  std::string lines;
  char line[320];
  for (const auto& object : truth.objects) {
    const auto& t = object.pose.translation;
    const auto& q = object.pose.rotation;
    const auto& a = object.symmetry_axis;
    std::snprintf(line, sizeof line,
                  "%" PRId64 ",%" PRId64 ",%d,%d,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", truth.frame,
                  truth.utime, object.id, object.is_hand ? 1 : 0, static_cast<double>(t.x()),
                  static_cast<double>(t.y()), static_cast<double>(t.z()), static_cast<double>(q.x()),
                  static_cast<double>(q.y()), static_cast<double>(q.z()), static_cast<double>(q.w()),
                  static_cast<double>(a.x()), static_cast<double>(a.y()), static_cast<double>(a.z()));
    lines += line;
  }
  append(poses_, (fs::path(folder_) / "poses.csv").string(), lines);
}

GroundTruthReader::GroundTruthReader(std::string folder) : folder_(std::move(folder)) {
  std::error_code error;
  if (!fs::is_directory(folder_, error)) throw DatasetError(folder_ + ": no such ground-truth folder");
  const std::string path = (fs::path(folder_) / "poses.csv").string();
  std::ifstream in(path);
  if (!in) throw DatasetError(path + ": missing or unreadable");
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    const std::string text = trim(line);
    if (text.empty() || text[0] == '#' || text.rfind("frame,", 0) == 0) continue;
    std::vector<std::string> fields;
    std::stringstream stream(text);
    std::string field;
    while (std::getline(stream, field, ',')) fields.push_back(trim(field));
    std::int64_t frame = 0, utime = 0, id = 0, is_hand = 0;
    double v[10] = {};
    const bool with_axis = fields.size() == 14;
    bool ok = (fields.size() == 11 || with_axis) && parse_int64(fields[0], frame) && frame >= 0 &&
              parse_int64(fields[1], utime) && parse_int64(fields[2], id) && id >= 1 && id <= 65535 &&
              parse_int64(fields[3], is_hand) && (is_hand == 0 || is_hand == 1);
    for (int k = 0; ok && k < (with_axis ? 10 : 7); ++k)
      ok = parse_double(fields[static_cast<std::size_t>(4 + k)], v[k]);
    if (ok && with_axis) {
      const double axis = std::sqrt(v[7] * v[7] + v[8] * v[8] + v[9] * v[9]);
      ok = axis == 0.0 || std::abs(axis - 1.0) < 1e-3;
    }
    if (ok) {
      const double norm = std::sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5] + v[6] * v[6]);
      ok = std::abs(norm - 1.0) < 1e-3;
    }
    if (!ok) {
      const std::string message = path + ":" + std::to_string(number) +
                                  ": expected 'frame,utime,object_id,is_hand,x,y,z,qx,qy,qz,qw[,axis_x,axis_y,axis_z]' "
                                  "with a unit quaternion and a unit or zero axis, line skipped";
      spdlog::warn("{}", message);
      warnings_.push_back(message);
      continue;
    }
    GroundTruthFrame& truth = frames_[frame];
    truth.frame = frame;
    truth.utime = utime;
    GroundTruthObject object;
    object.id = static_cast<int>(id);
    object.is_hand = is_hand == 1;
    object.pose.translation =
        Eigen::Vector3f(static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2]));
    object.pose.rotation = Eigen::Quaternionf(static_cast<float>(v[6]), static_cast<float>(v[3]),
                                              static_cast<float>(v[4]), static_cast<float>(v[5]))
                               .normalized();
    object.symmetry_axis =
        Eigen::Vector3f(static_cast<float>(v[7]), static_cast<float>(v[8]), static_cast<float>(v[9]));
    truth.objects.push_back(object);
  }
}

std::optional<Image16> GroundTruthReader::labels(std::int64_t frame) {
  try {
    return read_png16((fs::path(folder_) / "labels" / label_file_name(frame)).string());
  } catch (const ImageIoError& e) {
    spdlog::warn("{}", e.what());
    warnings_.push_back(e.what());
    return std::nullopt;
  }
}

// ---- writer ------------------------------------------------------------------------------------

void TumWriterOptions::validate() const {
  if (folder.empty()) throw std::invalid_argument("TumWriterOptions.folder must not be empty");
  if (!(depth_scale > 0.0 && std::isfinite(depth_scale))) {
    throw std::invalid_argument("TumWriterOptions.depth_scale must be finite and > 0 (units per metre)");
  }
}

TumDatasetWriter::TumDatasetWriter(TumWriterOptions options) : options_(std::move(options)) {
  options_.validate();
  const fs::path folder(options_.folder);
  std::error_code error;
  if (fs::exists(folder / "rgb.txt", error)) {
    throw DatasetError((folder / "rgb.txt").string() + ": already exists; choose a new folder for the dataset");
  }
  create_folder((folder / "rgb").string());
  create_folder((folder / "depth").string());
  if (options_.write_groundtruth) truth_.emplace((folder / "groundtruth").string());
  rgb_list_ = open_for_append((folder / "rgb.txt").string(), "# color images\n# timestamp filename\n");
  try {
    depth_list_ = open_for_append((folder / "depth.txt").string(), "# depth maps\n# timestamp filename\n");
  } catch (...) {
    close_file(rgb_list_);
    throw;
  }
}

TumDatasetWriter::~TumDatasetWriter() {
  close_file(rgb_list_);
  close_file(depth_list_);
}

void TumDatasetWriter::write(const Frame& frame, const GroundTruthFrame* truth) {
  try {
    frame.validate();
  } catch (const FrameCodecError& e) {
    throw DatasetError(options_.folder + ": cannot write " + e.what());
  }
  if (frame.capture_utime < 0 || (frames_written_ > 0 && frame.capture_utime <= last_utime_)) {
    throw DatasetError(options_.folder + ": frame timestamps must be >= 0 and strictly increasing (got " +
                       std::to_string(frame.capture_utime) + " us after " + std::to_string(last_utime_) + " us)");
  }
  const fs::path folder(options_.folder);
  if (frames_written_ == 0) {
    const std::string path = (folder / "intrinsics.txt").string();
    std::FILE* file = std::fopen((path + ".tmp").c_str(), "w");
    if (file == nullptr) throw DatasetError(path + ": cannot create: " + std::strerror(errno));
    const bool ok =
        std::fprintf(file, "# fx fy cx cy (pixels)\n%.9g %.9g %.9g %.9g\n", static_cast<double>(frame.fx),
                     static_cast<double>(frame.fy), static_cast<double>(frame.cx), static_cast<double>(frame.cy)) > 0;
    if (std::fclose(file) != 0 || !ok) throw DatasetError(path + ": cannot write");
    rename_into_place(path + ".tmp", path);
  }

  const std::string stamp = timestamp_text(frame.capture_utime);
  const std::string rgb_name = "rgb/" + stamp + ".png";
  const std::string depth_name = "depth/" + stamp + ".png";
  write_png_rgb_atomically((folder / rgb_name).string(), ImageRgb{frame.width, frame.height, frame.color});

  Image16 depth{frame.width, frame.height, std::vector<std::uint16_t>(frame.depth_mm.size())};
  const double to_units = options_.depth_scale / 1000.0;
  for (std::size_t i = 0; i < frame.depth_mm.size(); ++i) {
    const long long units = std::llround(frame.depth_mm[i] * to_units);
    if (units > 65535) {
      ++depth_pixels_clipped_;
      depth.pixels[i] = 0;
    } else {
      depth.pixels[i] = static_cast<std::uint16_t>(units);
    }
  }
  write_png16_atomically((folder / depth_name).string(), depth);

  if (truth != nullptr && truth_) truth_->write(*truth);
  append(rgb_list_, (folder / "rgb.txt").string(), stamp + " " + rgb_name + "\n");
  append(depth_list_, (folder / "depth.txt").string(), stamp + " " + depth_name + "\n");
  last_utime_ = frame.capture_utime;
  ++frames_written_;
}

}  // namespace mfot::service
