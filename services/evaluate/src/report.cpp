#include "mfot/evaluate/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>
#include <tuple>

namespace mfot::evaluate {

namespace fs = std::filesystem;

namespace {

std::ofstream open_output(const fs::path& path) {
  std::ofstream out(path);
  if (!out) throw EvaluationError(path.string() + ": cannot create file");
  out << std::setprecision(9);
  return out;
}

void close_output(std::ofstream& out, const fs::path& path) {
  out.close();
  if (!out) throw EvaluationError(path.string() + ": write failed");
}

// Minimal JSON emitter: values are written as they come; commas are tracked per nesting level.
class Json {
 public:
  explicit Json(std::ostream& out) : out_(out) {}
  Json& begin_object() { return open('{'); }
  Json& end_object() { return close('}'); }
  Json& begin_array() { return open('['); }
  Json& end_array() { return close(']'); }
  Json& key(const std::string& k) {
    separate();
    string(k);
    out_ << ": ";
    after_key_ = true;
    return *this;
  }
  Json& value(const std::string& v) {
    separate();
    string(v);
    return *this;
  }
  Json& value(const char* v) { return value(std::string(v)); }
  Json& value(bool v) {
    separate();
    out_ << (v ? "true" : "false");
    return *this;
  }
  Json& value(double v) {
    separate();
    if (std::isfinite(v))
      out_ << v;
    else
      out_ << "null";
    return *this;
  }
  template <class Int>
  requires std::is_integral_v<Int> Json& value(Int v) {
    separate();
    out_ << v;
    return *this;
  }

 private:
  Json& open(char c) {
    separate();
    out_ << c;
    first_.push_back(true);
    return *this;
  }
  Json& close(char c) {
    first_.pop_back();
    out_ << '\n' << std::string(2 * first_.size(), ' ') << c;
    return *this;
  }
  void separate() {
    if (after_key_) {
      after_key_ = false;
      return;
    }
    if (first_.empty()) return;
    if (!first_.back()) out_ << ',';
    out_ << '\n' << std::string(2 * first_.size(), ' ');
    first_.back() = false;
  }
  void string(const std::string& s) {
    out_ << '"';
    for (const char c : s) {
      switch (c) {
        case '"':
          out_ << "\\\"";
          break;
        case '\\':
          out_ << "\\\\";
          break;
        case '\n':
          out_ << "\\n";
          break;
        case '\t':
          out_ << "\\t";
          break;
        default:
          if (static_cast<unsigned char>(c) < 0x20) {
            char buf[8];
            std::snprintf(buf, sizeof(buf), "\\u%04x", c);
            out_ << buf;
          } else {
            out_ << c;
          }
      }
    }
    out_ << '"';
  }

  std::ostream& out_;
  std::vector<bool> first_;
  bool after_key_ = false;
};

void write_summary(Json& j, const PoseErrorSummary& s) {
  j.begin_object();
  j.key("frames").value(s.count);
  j.key("translation_mean_mm").value(s.translation_mean_mm);
  j.key("translation_median_mm").value(s.translation_median_mm);
  j.key("translation_max_mm").value(s.translation_max_mm);
  j.key("rotation_mean_deg").value(s.rotation_mean_deg);
  j.key("rotation_median_deg").value(s.rotation_median_deg);
  j.key("rotation_max_deg").value(s.rotation_max_deg);
  j.key("observable_rotation_median_deg").value(s.observable_rotation_median_deg);
  j.key("observable_rotation_max_deg").value(s.observable_rotation_max_deg);
  j.key("share_translation_over").value(s.share_translation_over);
  j.key("share_rotation_over").value(s.share_rotation_over);
  j.key("share_either_over").value(s.share_either_over);
  j.end_object();
}

// Pose error over all objects of a run (the frames after each object's t0), for the table.
PoseErrorSummary run_pose_summary(const RunResult& run, const EvaluationOptions& options) {
  std::vector<PoseError> all;
  for (const auto& o : run.objects) {
    if (o.errors.size() > 1) all.insert(all.end(), o.errors.begin() + 1, o.errors.end());
  }
  return summarize(all, {options.translation_threshold_mm, options.rotation_threshold_deg});
}

std::string fixed(double v, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

}  // namespace

void check_run_name(const std::string& name) {
  const bool ok = !name.empty() &&
                  name.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-.") ==
                      std::string::npos &&
                  name != "." && name != "..";
  if (!ok) throw EvaluationError("run name '" + name + "': use letters, digits, '_', '-' and '.' only");
}

void write_run_tables(const fs::path& out_dir, const RunResult& run) {
  const fs::path frames_path = out_dir / (run.name + "_frames.csv");
  auto frames = open_output(frames_path);
  frames << "frame,segmented,points,accuracy,fitting_mean_m,predicted_objects\n";
  for (const auto& f : run.frames) {
    frames << f.frame << ',' << (f.segmented ? 1 : 0) << ',' << f.points << ',';
    if (f.segmented) frames << f.accuracy;
    frames << ',';
    if (f.has_fitting) frames << f.fitting_mean_m;
    frames << ',' << f.predicted_objects << '\n';
  }
  close_output(frames, frames_path);

  const fs::path objects_path = out_dir / (run.name + "_objects.csv");
  auto objects = open_output(objects_path);
  objects << "groundtruth_id,is_hand,predicted_id,groundtruth_first_frame,groundtruth_last_frame,"
             "predicted_first_frame,predicted_last_frame,lost,compared_frames,stale_frames,"
             "translation_mean_mm,translation_median_mm,translation_max_mm,rotation_mean_deg,rotation_median_deg,"
             "rotation_max_deg,share_translation_over,share_rotation_over,share_either_over\n";
  for (const auto& o : run.objects) {
    const auto& s = o.summary;
    objects << o.groundtruth_id << ',' << (o.is_hand ? 1 : 0) << ',' << o.predicted_id << ','
            << o.groundtruth_first_frame << ',' << o.groundtruth_last_frame << ',' << o.predicted_first_frame << ','
            << o.predicted_last_frame << ',' << (o.lost ? 1 : 0) << ',' << o.frames.size() << ',' << o.stale_frames
            << ',' << s.translation_mean_mm << ',' << s.translation_median_mm << ',' << s.translation_max_mm << ','
            << s.rotation_mean_deg << ',' << s.rotation_median_deg << ',' << s.rotation_max_deg << ','
            << s.share_translation_over << ',' << s.share_rotation_over << ',' << s.share_either_over << '\n';
  }
  close_output(objects, objects_path);

  const fs::path errors_path = out_dir / (run.name + "_pose_errors.csv");
  auto errors = open_output(errors_path);
  errors << "frame,groundtruth_id,predicted_id,translation_mm,rotation_deg,observable_rotation_deg\n";
  for (const auto& o : run.objects) {
    for (std::size_t k = 0; k < o.frames.size(); ++k) {
      errors << o.frames[k] << ',' << o.groundtruth_id << ',' << o.predicted_id << ',' << o.errors[k].translation_mm
             << ',' << o.errors[k].rotation_deg << ',' << o.errors[k].observable_rotation_deg << '\n';
    }
  }
  close_output(errors, errors_path);

  const fs::path segments_path = out_dir / (run.name + "_segments.csv");
  auto segments = open_output(segments_path);
  segments << "groundtruth_id,predicted_id,mapped_groundtruth_id,points,share_of_points,share_of_groundtruth,frames\n";
  std::map<std::int32_t, std::uint64_t> groundtruth_points;
  for (const auto& o : run.overlaps) groundtruth_points[o.ground_truth] += o.points;
  std::vector<SegmentationAccuracy::Overlap> rows = run.overlaps;
  std::sort(rows.begin(), rows.end(), [](const auto& a, const auto& b) {
    return std::tie(a.ground_truth, b.points, a.predicted) < std::tie(b.ground_truth, a.points, b.predicted);
  });
  for (const auto& o : rows) {
    const auto mapped = run.mapping.find(o.predicted);
    segments << o.ground_truth << ',' << o.predicted << ','
             << (mapped == run.mapping.end() ? SegmentationAccuracy::kUnmatched : mapped->second) << ',' << o.points
             << ',' << static_cast<double>(o.points) / static_cast<double>(std::max<std::size_t>(run.points, 1)) << ','
             << static_cast<double>(o.points) / static_cast<double>(groundtruth_points.at(o.ground_truth)) << ','
             << o.frames << '\n';
  }
  close_output(segments, segments_path);
}

void write_summary_json(const fs::path& file, const std::vector<RunResult>& runs, const EvaluationOptions& options) {
  auto out = open_output(file);
  Json j(out);
  j.begin_object();
  j.key("translation_threshold_mm").value(options.translation_threshold_mm);
  j.key("rotation_threshold_deg").value(options.rotation_threshold_deg);
  j.key("runs").begin_array();
  for (const auto& run : runs) {
    j.begin_object();
    j.key("name").value(run.name);
    j.key("directory").value(run.directory.string());
    j.key("segmentation").begin_object();
    j.key("accuracy").value(run.accuracy);
    j.key("points").value(run.points);
    j.key("pixel_accuracy").value(run.pixel_accuracy);
    j.key("pixels").value(run.pixels);
    j.key("frames").value(run.segmented_frames);
    j.key("groundtruth_frames_without_prediction").value(run.groundtruth_frames_without_prediction);
    j.key("depth_mask").value(run.depth_mask);
    j.key("mapping").begin_object();
    for (const auto& [pred, gt] : run.mapping) {
      if (pred != 0) j.key(std::to_string(pred)).value(gt);
    }
    j.end_object();
    j.end_object();
    j.key("pose_error");
    write_summary(j, run_pose_summary(run, options));
    j.key("tracks_lost").value(run.tracks_lost);
    j.key("hands_lost").value(run.hands_lost);
    j.key("fitting_distance_mean_m").value(run.has_fitting ? run.fitting_mean_m : std::nan(""));
    j.key("objects").begin_array();
    for (const auto& o : run.objects) {
      j.begin_object();
      j.key("groundtruth_id").value(o.groundtruth_id);
      j.key("is_hand").value(o.is_hand);
      j.key("predicted_id").value(o.predicted_id);
      j.key("groundtruth_first_frame").value(o.groundtruth_first_frame);
      j.key("groundtruth_last_frame").value(o.groundtruth_last_frame);
      j.key("predicted_first_frame").value(o.predicted_first_frame);
      j.key("predicted_last_frame").value(o.predicted_last_frame);
      j.key("lost").value(o.lost);
      j.key("symmetric").value(o.symmetric);
      j.key("compared_frames").value(o.frames.size());
      j.key("stale_frames").value(o.stale_frames);
      j.key("pose_error");
      write_summary(j, o.summary);
      j.end_object();
    }
    j.end_array();
    j.key("timing").begin_array();
    for (const auto& t : run.timing) {
      j.begin_object();
      j.key("column").value(t.name);
      j.key("count").value(t.count);
      j.key("mean").value(t.mean);
      j.key("median").value(t.median);
      j.key("p95").value(t.p95);
      j.key("max").value(t.max);
      j.end_object();
    }
    j.end_array();
    j.end_object();
  }
  j.end_array();
  j.end_object();
  out << '\n';
  close_output(out, file);
}

void print_table(std::ostream& out, const std::vector<RunResult>& runs, const EvaluationOptions& options) {
  out << std::left << std::setw(16) << "run" << std::right << std::setw(8) << "frames" << std::setw(10) << "seg acc %"
      << std::setw(10) << "pixel %" << std::setw(9) << "objects" << std::setw(6) << "lost" << std::setw(11)
      << "t mean mm" << std::setw(10) << "t med mm" << std::setw(10) << "t max mm" << std::setw(11) << "r mean deg"
      << std::setw(10) << "r max deg" << std::setw(9) << "> thr %" << std::setw(11) << "fit mm" << '\n';
  for (const auto& run : runs) {
    const auto s = run_pose_summary(run, options);
    std::size_t objects = 0;
    for (const auto& o : run.objects) objects += o.is_hand ? 0 : 1;
    out << std::left << std::setw(16) << run.name << std::right << std::setw(8) << run.segmented_frames << std::setw(10)
        << fixed(100.0 * run.accuracy, 2) << std::setw(10) << fixed(100.0 * run.pixel_accuracy, 2) << std::setw(9)
        << objects << std::setw(6) << run.tracks_lost << std::setw(11) << fixed(s.translation_mean_mm, 2)
        << std::setw(10) << fixed(s.translation_median_mm, 2) << std::setw(10) << fixed(s.translation_max_mm, 2)
        << std::setw(11) << fixed(s.rotation_mean_deg, 2) << std::setw(10) << fixed(s.rotation_max_deg, 2)
        << std::setw(9) << fixed(100.0 * s.share_either_over, 1) << std::setw(11)
        << (run.has_fitting ? fixed(1000.0 * run.fitting_mean_m, 3) : std::string("-")) << '\n';
  }
  out << "(seg acc: scene points, thesis 4.3; pixel: every measured pixel, what preprocessing removed counted as "
         "unlabelled)\n";
  out << "(obs r: for objects symmetric about an axis, the rotation error of that axis's direction, without the "
         "turn about it that shape cannot show)\n";
  out << "(pose error over all objects' frames after their first tracked frame; > thr: share of frames over "
      << fixed(options.translation_threshold_mm, 1) << " mm or " << fixed(options.rotation_threshold_deg, 1)
      << " deg; objects and lost exclude hands)\n";
  for (const auto& run : runs) {
    out << '\n' << run.name << ": per object (depth mask: " << run.depth_mask << ")\n";
    out << std::right << std::setw(6) << "gt id" << std::setw(6) << "hand" << std::setw(8) << "pred id" << std::setw(7)
        << "lost" << std::setw(8) << "frames" << std::setw(11) << "t mean mm" << std::setw(10) << "t med mm"
        << std::setw(10) << "t max mm" << std::setw(11) << "r mean deg" << std::setw(10) << "r med deg" << std::setw(10)
        << "r max deg" << std::setw(9) << ">1cm %" << std::setw(9) << ">5deg %" << std::setw(13) << "obs r med"
        << std::setw(10) << "obs r max" << '\n';
    for (const auto& o : run.objects) {
      const auto& s = o.summary;
      out << std::setw(6) << o.groundtruth_id << std::setw(6) << (o.is_hand ? "yes" : "no") << std::setw(8)
          << (o.predicted_id ? std::to_string(o.predicted_id) : std::string("-")) << std::setw(7)
          << (o.lost ? "yes" : "no") << std::setw(8) << o.frames.size() << std::setw(11)
          << fixed(s.translation_mean_mm, 2) << std::setw(10) << fixed(s.translation_median_mm, 2) << std::setw(10)
          << fixed(s.translation_max_mm, 2) << std::setw(11) << fixed(s.rotation_mean_deg, 2) << std::setw(10)
          << fixed(s.rotation_median_deg, 2) << std::setw(10) << fixed(s.rotation_max_deg, 2) << std::setw(9)
          << fixed(100.0 * s.share_translation_over, 1) << std::setw(9) << fixed(100.0 * s.share_rotation_over, 1);
      // Symmetric objects (a can): the rotation error without the unobservable turn about the axis.
      if (o.symmetric) {
        out << std::setw(13) << fixed(s.observable_rotation_median_deg, 2) << std::setw(10)
            << fixed(s.observable_rotation_max_deg, 2);
      } else {
        out << std::setw(13) << "-" << std::setw(10) << "-";
      }
      out << '\n';
    }
    for (const auto& t : run.timing) {
      out << "  timing " << t.name << ": mean " << fixed(t.mean, 3) << ", median " << fixed(t.median, 3) << ", p95 "
          << fixed(t.p95, 3) << ", max " << fixed(t.max, 3) << " (" << t.count << " rows)\n";
    }
  }
}

std::vector<std::int64_t> spread_segmented_frames(const RunResult& run, std::size_t count) {
  std::vector<std::int64_t> segmented;
  for (const auto& f : run.frames) {
    if (f.segmented) segmented.push_back(f.frame);
  }
  if (segmented.size() <= count) return segmented;
  std::vector<std::int64_t> chosen;
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t index = count == 1 ? 0 : k * (segmented.size() - 1) / (count - 1);
    chosen.push_back(segmented[index]);
  }
  return chosen;
}

void write_plot_spec(const fs::path& file, const fs::path& out_dir, const std::vector<RunResult>& runs,
                     const GroundTruth& groundtruth, const std::vector<std::vector<std::int64_t>>& segmentation_frames,
                     const EvaluationOptions& options) {
  auto out = open_output(file);
  Json j(out);
  j.begin_object();
  j.key("fitting").begin_object();
  j.key("out").value((out_dir / "fitting_distance.png").string());
  j.key("runs").begin_array();
  for (const auto& run : runs) {
    if (!run.has_fitting) continue;
    j.begin_object();
    j.key("name").value(run.name);
    j.key("frames_csv").value((out_dir / (run.name + "_frames.csv")).string());
    j.end_object();
  }
  j.end_array();
  j.end_object();
  j.key("pose_error").begin_array();
  for (const auto& run : runs) {
    j.begin_object();
    j.key("name").value(run.name);
    j.key("csv").value((out_dir / (run.name + "_pose_errors.csv")).string());
    j.key("out").value((out_dir / ("pose_error_" + run.name + ".png")).string());
    j.key("translation_threshold_mm").value(options.translation_threshold_mm);
    j.key("rotation_threshold_deg").value(options.rotation_threshold_deg);
    j.end_object();
  }
  j.end_array();
  j.key("segmentation").begin_array();
  for (std::size_t r = 0; r < runs.size(); ++r) {
    const auto& run = runs[r];
    std::map<std::int64_t, double> accuracy;
    for (const auto& f : run.frames) {
      if (f.segmented) accuracy[f.frame] = f.accuracy;
    }
    for (const std::int64_t frame : segmentation_frames.at(r)) {
      if (!accuracy.contains(frame)) continue;
      j.begin_object();
      j.key("name").value(run.name);
      j.key("frame").value(frame);
      j.key("accuracy").value(accuracy[frame]);
      j.key("predicted").value(frame_image(run.directory / "labels", frame).string());
      j.key("groundtruth").value(frame_image(groundtruth.directory / "labels", frame).string());
      j.key("mapping").begin_object();
      for (const auto& [pred, gt] : run.mapping) {
        if (pred != 0) j.key(std::to_string(pred)).value(gt);
      }
      j.end_object();
      char name[64];
      std::snprintf(name, sizeof(name), "_%06lld.png", static_cast<long long>(frame));
      j.key("out").value((out_dir / ("segmentation_" + run.name + name)).string());
      j.end_object();
    }
  }
  j.end_array();
  j.end_object();
  out << '\n';
  close_output(out, file);
}

}  // namespace mfot::evaluate
