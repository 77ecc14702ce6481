#include "mfot/evaluate/evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <regex>
#include <set>
#include <stdexcept>

#include "mfot/service/image_io.hpp"
#include "mfot/service/run_writer.hpp"

namespace mfot::evaluate {

namespace fs = std::filesystem;

namespace {

constexpr std::int64_t kMaxFrame = std::numeric_limits<std::int64_t>::max();
constexpr std::int64_t kMaxId = std::numeric_limits<std::int32_t>::max();

Pose read_pose(const CsvTable& t, std::size_t row) {
  Pose pose;
  pose.translation = Eigen::Vector3f(static_cast<float>(t.number(row, t.column("x"))),
                                     static_cast<float>(t.number(row, t.column("y"))),
                                     static_cast<float>(t.number(row, t.column("z"))));
  const Eigen::Quaterniond q(t.number(row, t.column("qw")), t.number(row, t.column("qx")),
                             t.number(row, t.column("qy")), t.number(row, t.column("qz")));
  // A quaternion far from unit length means a broken writer, not rounding.
  if (std::abs(q.norm() - 1.0) > 1e-3) {
    throw EvaluationError(t.where(row) + "quaternion (qx,qy,qz,qw) has norm " + std::to_string(q.norm()) +
                          ", expected a unit quaternion");
  }
  pose.rotation = q.normalized().cast<float>();
  return pose;
}

template <class Row>
void reject_duplicates(const CsvTable& t, const std::vector<Row>& rows) {
  std::set<std::pair<std::int64_t, std::int32_t>> seen;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (!seen.emplace(rows[i].frame, rows[i].id).second) {
      throw EvaluationError(t.where(i) + "object " + std::to_string(rows[i].id) + " appears twice in frame " +
                            std::to_string(rows[i].frame));
    }
  }
}

double percentile_nearest_rank(const std::vector<double>& sorted, double p) {
  const auto rank = static_cast<std::size_t>(std::ceil(p * static_cast<double>(sorted.size())));
  return sorted[std::clamp<std::size_t>(rank, 1, sorted.size()) - 1];
}

}  // namespace

std::vector<PredictedPoseRow> read_predicted_poses(const fs::path& csv) {
  const CsvTable t = CsvTable::read(
      csv, {"frame", "utime", "object_id", "x", "y", "z", "qx", "qy", "qz", "qw", "confidence", "stale"});
  std::vector<PredictedPoseRow> rows(t.rows());
  for (std::size_t i = 0; i < t.rows(); ++i) {
    auto& r = rows[i];
    r.frame = t.integer(i, t.column("frame"), 0, kMaxFrame);
    r.utime = t.integer(i, t.column("utime"), 0, kMaxFrame);
    r.id = static_cast<std::int32_t>(t.integer(i, t.column("object_id"), 1, kMaxId));
    r.pose = read_pose(t, i);
    r.confidence = t.number(i, t.column("confidence"));
    r.stale = t.boolean(i, t.column("stale"));
  }
  reject_duplicates(t, rows);
  return rows;
}

std::vector<GroundTruthPoseRow> read_groundtruth_poses(const fs::path& csv) {
  const CsvTable t =
      CsvTable::read(csv, {"frame", "utime", "object_id", "is_hand", "x", "y", "z", "qx", "qy", "qz", "qw"});
  std::vector<GroundTruthPoseRow> rows(t.rows());
  for (std::size_t i = 0; i < t.rows(); ++i) {
    auto& r = rows[i];
    r.frame = t.integer(i, t.column("frame"), 0, kMaxFrame);
    r.utime = t.integer(i, t.column("utime"), 0, kMaxFrame);
    r.id = static_cast<std::int32_t>(t.integer(i, t.column("object_id"), 1, kMaxId));
    r.is_hand = t.boolean(i, t.column("is_hand"));
    r.pose = read_pose(t, i);
    if (t.has_column("axis_x") && t.has_column("axis_y") && t.has_column("axis_z")) {
      r.symmetry_axis = Eigen::Vector3f(static_cast<float>(t.number(i, t.column("axis_x"))),
                                        static_cast<float>(t.number(i, t.column("axis_y"))),
                                        static_cast<float>(t.number(i, t.column("axis_z"))));
    }
  }
  reject_duplicates(t, rows);
  return rows;
}

std::map<std::int64_t, double> read_fitting_means(const fs::path& csv) {
  const CsvTable t = CsvTable::read(csv, {"frame", "object_id", "fitting_distance_m"});
  std::map<std::int64_t, std::pair<double, int>> sums;
  for (std::size_t i = 0; i < t.rows(); ++i) {
    const std::int64_t frame = t.integer(i, t.column("frame"), 0, kMaxFrame);
    t.integer(i, t.column("object_id"), 1, kMaxId);
    const double d = t.number(i, t.column("fitting_distance_m"));
    if (d < 0.0) throw EvaluationError(t.where(i) + "column 'fitting_distance_m': negative distance");
    auto& [sum, count] = sums[frame];
    sum += d;
    ++count;
  }
  std::map<std::int64_t, double> means;
  for (const auto& [frame, sc] : sums) means.emplace(frame, sc.first / sc.second);
  return means;
}

std::vector<TimingColumn> read_timing(const fs::path& csv) {
  const CsvTable t = CsvTable::read(csv, {});
  std::vector<TimingColumn> result;
  for (std::size_t c = 0; c < t.columns().size(); ++c) {
    const std::string& name = t.columns()[c];
    if (name == "frame" || name == "utime") continue;
    std::vector<double> values;
    values.reserve(t.rows());
    for (std::size_t i = 0; i < t.rows(); ++i) values.push_back(t.number(i, c));
    TimingColumn col;
    col.name = name;
    col.count = values.size();
    if (!values.empty()) {
      std::sort(values.begin(), values.end());
      double sum = 0.0;
      for (double v : values) sum += v;
      col.mean = sum / static_cast<double>(values.size());
      const std::size_t n = values.size();
      col.median = n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
      col.p95 = percentile_nearest_rank(values, 0.95);
      col.max = values.back();
    }
    result.push_back(col);
  }
  return result;
}

std::vector<std::int64_t> label_frames(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw EvaluationError(dir.string() + ": label directory not found");
  static const std::regex name(R"(^([0-9]+)\.png$)");
  std::vector<std::int64_t> frames;
  for (const auto& entry : fs::directory_iterator(dir)) {
    std::smatch m;
    const std::string file = entry.path().filename().string();
    if (entry.is_regular_file() && std::regex_match(file, m, name)) frames.push_back(std::stoll(m[1].str()));
  }
  std::sort(frames.begin(), frames.end());
  return frames;
}

fs::path frame_image(const fs::path& dir, std::int64_t frame) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06lld.png", static_cast<long long>(frame));
  return dir / name;
}

GroundTruth load_groundtruth(const fs::path& directory) {
  std::error_code ec;
  if (!fs::is_directory(directory, ec)) {
    throw EvaluationError(directory.string() + ": ground-truth directory not found");
  }
  GroundTruth gt;
  gt.directory = directory;
  gt.poses = read_groundtruth_poses(directory / "poses.csv");
  gt.label_frames = label_frames(directory / "labels");
  return gt;
}

void EvaluationOptions::validate() const {
  if (!(translation_threshold_mm > 0.0 && translation_threshold_mm <= 1000.0)) {
    throw std::invalid_argument("EvaluationOptions.translation_threshold_mm must be in (0, 1000]");
  }
  if (!(rotation_threshold_deg > 0.0 && rotation_threshold_deg <= 180.0)) {
    throw std::invalid_argument("EvaluationOptions.rotation_threshold_deg must be in (0, 180]");
  }
}

namespace {

service::Image16 read_labels(const fs::path& path) {
  try {
    return service::read_png16(path.string());
  } catch (const service::ImageIoError& e) {
    throw EvaluationError(e.what());
  }
}

void require_same_size(const service::Image16& a, const fs::path& pa, const service::Image16& b, const fs::path& pb) {
  if (a.width != b.width || a.height != b.height) {
    throw EvaluationError(pa.string() + " is " + std::to_string(a.width) + "x" + std::to_string(a.height) + " but " +
                          pb.string() + " is " + std::to_string(b.width) + "x" + std::to_string(b.height));
  }
}

struct Visibility {
  std::int64_t first = kMaxFrame;
  std::int64_t last = -1;
};

}  // namespace

RunResult evaluate_run(const std::string& name, const fs::path& run_directory, const GroundTruth& groundtruth,
                       const EvaluationOptions& options) {
  options.validate();
  std::error_code ec;
  if (!fs::is_directory(run_directory, ec)) throw EvaluationError(run_directory.string() + ": run directory not found");
  RunResult result;
  result.name = name;
  result.directory = run_directory;

  const auto predicted = read_predicted_poses(run_directory / "poses.csv");
  const fs::path run_labels = run_directory / "labels";
  const auto run_label_frames = label_frames(run_labels);
  std::map<std::int64_t, double> fitting;
  if (fs::exists(run_directory / "fitting.csv")) {
    fitting = read_fitting_means(run_directory / "fitting.csv");
    result.has_fitting = !fitting.empty();
  }
  if (fs::exists(run_directory / "timing.csv")) result.timing = read_timing(run_directory / "timing.csv");

  fs::path depth_dir;
  if (fs::is_directory(groundtruth.directory / "depth", ec)) {
    depth_dir = groundtruth.directory / "depth";
  } else if (fs::is_directory(run_directory / "depth", ec)) {
    depth_dir = run_directory / "depth";
  }
  result.depth_mask = depth_dir.empty() ? "none" : depth_dir.string();

  // Step 1 and 2: segmentation over the frames with both label images.
  std::vector<std::int64_t> segmented;
  std::set_intersection(groundtruth.label_frames.begin(), groundtruth.label_frames.end(), run_label_frames.begin(),
                        run_label_frames.end(), std::back_inserter(segmented));
  result.segmented_frames = segmented.size();
  result.groundtruth_frames_without_prediction = groundtruth.label_frames.size() - segmented.size();
  SegmentationAccuracy accuracy;               // scene points (thesis 4.3)
  SegmentationAccuracy pixel_accuracy;         // every measured pixel labelled in either image
  std::map<std::int32_t, Visibility> visible;  // ground-truth id -> frames it has points in
  std::vector<std::size_t> frame_points;
  std::vector<std::int32_t> pred_points, gt_points, pred_pixels, gt_pixels;
  for (const std::int64_t frame : segmented) {
    const fs::path pred_path = frame_image(run_labels, frame);
    const fs::path gt_path = frame_image(groundtruth.directory / "labels", frame);
    const auto pred = read_labels(pred_path);
    const auto gt = read_labels(gt_path);
    require_same_size(pred, pred_path, gt, gt_path);
    service::Image16 depth;
    if (!depth_dir.empty()) {
      const fs::path depth_path = frame_image(depth_dir, frame);
      if (!fs::exists(depth_path))
        throw EvaluationError(depth_path.string() + ": depth image missing for frame " + std::to_string(frame));
      depth = read_labels(depth_path);
      require_same_size(depth, depth_path, gt, gt_path);
    }
    pred_points.clear();
    gt_points.clear();
    pred_pixels.clear();
    gt_pixels.clear();
    for (std::size_t i = 0; i < gt.pixels.size(); ++i) {
      const bool scene_point = pred.pixels[i] != service::kNotScenePoint;
      const std::int32_t predicted = scene_point ? pred.pixels[i] : 0;
      if (predicted == 0 && gt.pixels[i] == 0) continue;
      if (!depth_dir.empty() && depth.pixels[i] == 0) continue;
      pred_pixels.push_back(predicted);
      gt_pixels.push_back(gt.pixels[i]);
      if (!scene_point) continue;
      pred_points.push_back(predicted);
      gt_points.push_back(gt.pixels[i]);
      if (gt.pixels[i] != 0) {
        auto& v = visible[gt.pixels[i]];
        v.first = std::min(v.first, frame);
        v.last = std::max(v.last, frame);
      }
    }
    accuracy.add_frame(pred_points, gt_points);
    pixel_accuracy.add_frame(pred_pixels, gt_pixels);
    frame_points.push_back(pred_points.size());
  }
  result.points = accuracy.points();
  result.accuracy = accuracy.accuracy();
  result.pixels = pixel_accuracy.points();
  result.pixel_accuracy = pixel_accuracy.accuracy();
  result.mapping = accuracy.mapping();
  result.overlaps = accuracy.overlaps();
  const auto frame_accuracy = accuracy.frame_accuracies();

  // Per-frame table: every frame the run has labels, poses or fitting for.
  std::map<std::int64_t, FrameResult> frames;
  for (std::size_t k = 0; k < segmented.size(); ++k) {
    auto& f = frames[segmented[k]];
    f.segmented = true;
    f.points = frame_points[k];
    f.accuracy = frame_accuracy[k];
  }
  for (const auto& row : predicted) ++frames[row.frame].predicted_objects;
  double fitting_sum = 0.0;
  for (const auto& [frame, mean] : fitting) {
    auto& f = frames[frame];
    f.has_fitting = true;
    f.fitting_mean_m = mean;
    fitting_sum += mean;
  }
  if (result.has_fitting) result.fitting_mean_m = fitting_sum / static_cast<double>(fitting.size());
  for (auto& [frame, f] : frames) {
    f.frame = frame;
    result.frames.push_back(f);
  }

  // Step 3 and 4: objects through the segmentation mapping.
  std::map<std::int32_t, std::int32_t> predicted_for;  // gt id -> predicted id
  for (const auto& [pred_id, gt_id] : result.mapping) {
    if (pred_id != 0 && gt_id > 0) predicted_for[gt_id] = pred_id;
  }
  std::map<std::int32_t, std::map<std::int64_t, const PredictedPoseRow*>> predicted_by_id;
  for (const auto& row : predicted) predicted_by_id[row.id][row.frame] = &row;
  std::map<std::int32_t, std::map<std::int64_t, const GroundTruthPoseRow*>> groundtruth_by_id;
  std::map<std::int32_t, bool> is_hand;
  std::map<std::int32_t, Eigen::Vector3f> symmetry_axis;
  for (const auto& row : groundtruth.poses) {
    groundtruth_by_id[row.id][row.frame] = &row;
    is_hand[row.id] = is_hand[row.id] || row.is_hand;
    if (row.symmetry_axis.squaredNorm() > 0.f) symmetry_axis[row.id] = row.symmetry_axis;
  }
  const PoseErrorSummaryOptions summary_options{options.translation_threshold_mm, options.rotation_threshold_deg};
  for (const auto& [gt_id, seen] : visible) {
    ObjectResult object;
    object.groundtruth_id = gt_id;
    object.is_hand = is_hand[gt_id];
    const auto axis = symmetry_axis.find(gt_id);
    object.symmetric = axis != symmetry_axis.end();
    object.groundtruth_first_frame = seen.first;
    object.groundtruth_last_frame = seen.last;
    const auto mapped = predicted_for.find(gt_id);
    if (mapped != predicted_for.end()) {
      object.predicted_id = mapped->second;
      const auto& track = predicted_by_id[object.predicted_id];
      const auto& truth = groundtruth_by_id[gt_id];
      if (!track.empty()) object.predicted_first_frame = track.begin()->first;
      std::vector<Pose> pred_poses, gt_poses;
      for (const auto& [frame, row] : track) {
        if (!row->stale) object.predicted_last_frame = frame;
        const auto it = truth.find(frame);
        if (it == truth.end()) continue;
        object.frames.push_back(frame);
        pred_poses.push_back(row->pose);
        gt_poses.push_back(it->second->pose);
        object.stale_frames += row->stale ? 1 : 0;
      }
      object.errors =
          relative_pose_errors(pred_poses, gt_poses, object.symmetric ? axis->second : Eigen::Vector3f::Zero());
      if (object.errors.size() > 1) {
        object.summary = summarize(std::span<const PoseError>(object.errors).subspan(1), summary_options);
      }
    }
    object.lost = object.predicted_id == 0 || object.predicted_last_frame < object.groundtruth_last_frame;
    if (object.lost) ++(object.is_hand ? result.hands_lost : result.tracks_lost);
    result.objects.push_back(std::move(object));
  }
  return result;
}

}  // namespace mfot::evaluate
