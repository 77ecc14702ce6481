// mfot-evaluate's library on synthetic recordings whose expected numbers follow from how they
// were made: ground truth against itself, known label and pose perturbations, the depth mask,
// and bad inputs.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numbers>
#include <random>
#include <sstream>
#include <tuple>

#include "mfot/evaluate/evaluation.hpp"
#include "mfot/evaluate/report.hpp"
#include "mfot/service/image_io.hpp"
#include "mfot/service/run_writer.hpp"

namespace {

namespace fs = std::filesystem;
using namespace mfot;
using namespace mfot::evaluate;

constexpr int kWidth = 40;
constexpr int kHeight = 30;
constexpr int kFrames = 10;

struct Rect {
  int x0, y0, x1, y1;  // inclusive
  int area() const { return (x1 - x0 + 1) * (y1 - y0 + 1); }
};

// Ground-truth objects: id, image rectangle, pose over time.
struct Body {
  int id;
  bool is_hand;
  Rect rect;
  std::function<Pose(int)> pose;
};

Eigen::Quaternionf axis_angle(float degrees, const Eigen::Vector3f& axis) {
  return Eigen::Quaternionf(Eigen::AngleAxisf(degrees * std::numbers::pi_v<float> / 180.0f, axis.normalized()));
}

std::vector<Body> scene_bodies() {
  return {
      // Object 1 starts on the optical axis and only translates along x.
      {1,
       false,
       {2, 2, 9, 9},
       [](int t) {
         Pose p;
         p.translation = Eigen::Vector3f(0.005f * t, 0.0f, 0.8f);
         p.rotation = axis_angle(17.0f, {1, 0, 0});
         return p;
       }},
      // Object 2 translates along y and turns about its own z axis.
      {2,
       false,
       {20, 10, 29, 19},
       [](int t) {
         Pose p;
         p.translation = Eigen::Vector3f(0.1f, -0.05f + 0.003f * t, 0.9f);
         p.rotation = axis_angle(2.0f * t, {0, 0, 1}) * axis_angle(30.0f, {0, 1, 0});
         return p;
       }},
      // Object 3 never moves.
      {3,
       false,
       {30, 24, 35, 27},
       [](int) {
         Pose p;
         p.translation = Eigen::Vector3f(-0.2f, 0.1f, 1.1f);
         return p;
       }},
  };
}

class TempDir {
 public:
  TempDir() {
    std::random_device rd;
    path_ = fs::temp_directory_path() / ("mfot_evaluate_test_" + std::to_string(rd()) + std::to_string(rd()));
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

service::Image16 blank() {
  service::Image16 image;
  image.width = kWidth;
  image.height = kHeight;
  image.pixels.assign(kWidth * kHeight, 0);
  return image;
}

void fill(service::Image16& image, const Rect& r, std::uint16_t value) {
  for (int y = r.y0; y <= r.y1; ++y) {
    for (int x = r.x0; x <= r.x1; ++x) image.pixels[y * kWidth + x] = value;
  }
}

std::string pose_fields(const Pose& p) {
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g", p.translation.x(), p.translation.y(),
                p.translation.z(), p.rotation.x(), p.rotation.y(), p.rotation.z(), p.rotation.w());
  return buf;
}

void write_groundtruth(const fs::path& dir, const std::vector<Body>& bodies) {
  fs::create_directories(dir / "labels");
  std::ofstream csv(dir / "poses.csv");
  csv << "frame,utime,object_id,is_hand,x,y,z,qx,qy,qz,qw\n";
  for (int t = 0; t < kFrames; ++t) {
    auto labels = blank();
    for (const auto& b : bodies) {
      fill(labels, b.rect, static_cast<std::uint16_t>(b.id));
      csv << t << ',' << 1000 + 33333 * t << ',' << b.id << ',' << (b.is_hand ? 1 : 0) << ',' << pose_fields(b.pose(t))
          << '\n';
    }
    service::write_png16(frame_image(dir / "labels", t).string(), labels);
  }
}

// A run: which predicted id each ground-truth body gets (0: not tracked, no labels, no poses),
// plus hooks to perturb labels and poses.
struct RunSpec {
  std::map<int, int> predicted_id;  // gt id -> predicted id
  std::function<void(int frame, service::Image16&)> edit_labels = [](int, service::Image16&) {};
  std::function<Pose(int gt_id, int frame, const Pose&)> edit_pose = [](int, int, const Pose& p) { return p; };
  std::function<bool(int gt_id, int frame)> stale = [](int, int) { return false; };
};

void write_run(const fs::path& dir, const std::vector<Body>& bodies, const RunSpec& spec) {
  fs::create_directories(dir / "labels");
  std::ofstream csv(dir / "poses.csv");
  csv << "frame,utime,object_id,x,y,z,qx,qy,qz,qw,confidence,stale\n";
  for (int t = 0; t < kFrames; ++t) {
    auto labels = blank();
    for (const auto& b : bodies) {
      const int id = spec.predicted_id.count(b.id) ? spec.predicted_id.at(b.id) : 0;
      if (id == 0) continue;
      fill(labels, b.rect, static_cast<std::uint16_t>(id));
      csv << t << ',' << 1000 + 33333 * t << ',' << id << ',' << pose_fields(spec.edit_pose(b.id, t, b.pose(t)))
          << ",0.9," << (spec.stale(b.id, t) ? 1 : 0) << '\n';
    }
    spec.edit_labels(t, labels);
    service::write_png16(frame_image(dir / "labels", t).string(), labels);
  }
}

const ObjectResult& object_for(const RunResult& run, int gt_id) {
  for (const auto& o : run.objects) {
    if (o.groundtruth_id == gt_id) return o;
  }
  throw std::runtime_error("no object " + std::to_string(gt_id));
}

TEST(Evaluate, GroundTruthAgainstItselfIsPerfect) {
  TempDir tmp;
  const auto bodies = scene_bodies();
  write_groundtruth(tmp.path() / "gt", bodies);
  write_run(tmp.path() / "run", bodies, RunSpec{{{1, 1}, {2, 2}, {3, 3}}});
  const auto gt = load_groundtruth(tmp.path() / "gt");
  const auto run = evaluate_run("self", tmp.path() / "run", gt, {});

  EXPECT_EQ(run.segmented_frames, static_cast<std::size_t>(kFrames));
  EXPECT_EQ(run.groundtruth_frames_without_prediction, 0u);
  EXPECT_EQ(run.points, static_cast<std::size_t>(kFrames * (64 + 100 + 24)));
  EXPECT_DOUBLE_EQ(run.accuracy, 1.0);
  EXPECT_EQ(run.depth_mask, "none");
  EXPECT_EQ(run.mapping.at(1), 1);
  EXPECT_EQ(run.mapping.at(2), 2);
  EXPECT_EQ(run.mapping.at(3), 3);
  EXPECT_EQ(run.tracks_lost, 0u);
  ASSERT_EQ(run.objects.size(), 3u);
  for (const auto& o : run.objects) {
    EXPECT_FALSE(o.lost) << o.groundtruth_id;
    EXPECT_EQ(o.frames.size(), static_cast<std::size_t>(kFrames));
    EXPECT_EQ(o.summary.count, static_cast<std::size_t>(kFrames - 1));
    EXPECT_LT(o.summary.translation_max_mm, 1e-3);
    EXPECT_LT(o.summary.rotation_max_deg, 1e-2);
  }
  for (const auto& f : run.frames) EXPECT_DOUBLE_EQ(f.accuracy, 1.0);
}

TEST(Evaluate, KnownPerturbationGivesExpectedNumbers) {
  TempDir tmp;
  const auto bodies = scene_bodies();
  write_groundtruth(tmp.path() / "gt", bodies);
  RunSpec spec;
  spec.predicted_id = {{1, 7}, {2, 9}};  // object 3 is never tracked
  // Frame 4: 10 pixels of object 1 labelled as the prediction for object 2.
  // Frame 5: 6 background pixels labelled as object 1's prediction.
  spec.edit_labels = [](int frame, service::Image16& labels) {
    if (frame == 4) fill(labels, {2, 2, 6, 3}, 9);
    if (frame == 5) fill(labels, {12, 0, 14, 1}, 7);
  };
  // From frame 6: object 1 turned 8 deg about the camera z axis (its origin is on that axis, so
  // its motion's translation is unchanged); object 2 shifted 20 mm along x.
  constexpr int kFrom = 6;
  spec.edit_pose = [](int gt_id, int frame, const Pose& p) {
    Pose q = p;
    if (frame >= kFrom && gt_id == 1) q.rotation = axis_angle(8.0f, {0, 0, 1}) * p.rotation;
    if (frame >= kFrom && gt_id == 2) q.translation += Eigen::Vector3f(0.02f, 0.0f, 0.0f);
    return q;
  };
  // Object 2's prediction goes stale for the last two frames: it ends before the ground truth.
  spec.stale = [](int gt_id, int frame) { return gt_id == 2 && frame >= kFrames - 2; };
  write_run(tmp.path() / "run", bodies, spec);

  const auto gt = load_groundtruth(tmp.path() / "gt");
  const auto run = evaluate_run("perturbed", tmp.path() / "run", gt, {});

  const std::size_t labelled = kFrames * (64 + 100 + 24);
  EXPECT_EQ(run.points, labelled + 6);
  EXPECT_NEAR(run.accuracy, static_cast<double>(kFrames * (64 + 100) - 10) / static_cast<double>(labelled + 6), 1e-12);
  EXPECT_EQ(run.mapping.at(7), 1);
  EXPECT_EQ(run.mapping.at(9), 2);
  for (const auto& f : run.frames) {
    const double expected = f.frame == 4 ? (164.0 - 10.0) / 188.0 : f.frame == 5 ? 164.0 / 194.0 : 164.0 / 188.0;
    EXPECT_NEAR(f.accuracy, expected, 1e-12) << "frame " << f.frame;
  }

  const double perturbed_share = static_cast<double>(kFrames - kFrom) / (kFrames - 1);
  const auto& o1 = object_for(run, 1);
  EXPECT_EQ(o1.predicted_id, 7);
  EXPECT_FALSE(o1.lost);
  EXPECT_LT(o1.summary.translation_max_mm, 1e-3);
  EXPECT_NEAR(o1.summary.rotation_max_deg, 8.0, 1e-3);
  EXPECT_NEAR(o1.summary.rotation_mean_deg, 8.0 * perturbed_share, 1e-3);
  EXPECT_NEAR(o1.summary.rotation_median_deg, 0.0, 1e-2);  // 5 of 9 frames unperturbed
  EXPECT_DOUBLE_EQ(o1.summary.share_rotation_over, perturbed_share);
  EXPECT_DOUBLE_EQ(o1.summary.share_translation_over, 0.0);

  const auto& o2 = object_for(run, 2);
  EXPECT_EQ(o2.predicted_id, 9);
  EXPECT_TRUE(o2.lost);
  EXPECT_EQ(o2.predicted_last_frame, kFrames - 3);
  EXPECT_EQ(o2.stale_frames, 2u);
  EXPECT_NEAR(o2.summary.translation_max_mm, 20.0, 1e-3);
  EXPECT_NEAR(o2.summary.translation_mean_mm, 20.0 * perturbed_share, 1e-3);
  EXPECT_LT(o2.summary.rotation_max_deg, 1e-2);
  EXPECT_DOUBLE_EQ(o2.summary.share_translation_over, perturbed_share);

  const auto& o3 = object_for(run, 3);
  EXPECT_EQ(o3.predicted_id, 0);
  EXPECT_TRUE(o3.lost);
  EXPECT_TRUE(o3.frames.empty());
  EXPECT_EQ(run.tracks_lost, 2u);

  // Where the points went: the 10 pixels of object 1 given to object 2's prediction in one frame, the
  // 6 background pixels given to object 1's, object 3 never labelled; largest first per object.
  const fs::path out = tmp.path() / "out";
  fs::create_directories(out);
  write_run_tables(out, run);
  std::ifstream segments(out / "perturbed_segments.csv");
  std::string line;
  std::getline(segments, line);
  EXPECT_EQ(line,
            "groundtruth_id,predicted_id,mapped_groundtruth_id,points,share_of_points,share_of_groundtruth,frames");
  // (ground truth, predicted, mapped, points, frames) of each row; the shares are over all scene points (188 a
  // frame, and the 6 of frame 5) and over the ground-truth id's.
  std::vector<std::tuple<int, int, int, long, int>> rows;
  std::vector<std::pair<double, double>> shares;
  while (std::getline(segments, line)) {
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream fields(line);
    int gt = 0, predicted = 0, mapped = 0, frames = 0;
    long n = 0;
    double of_points = 0.0, of_groundtruth = 0.0;
    fields >> gt >> predicted >> mapped >> n >> of_points >> of_groundtruth >> frames;
    rows.emplace_back(gt, predicted, mapped, n, frames);
    shares.emplace_back(of_points, of_groundtruth);
  }
  const long all = kFrames * (64 + 100 + 24) + 6;
  EXPECT_EQ(rows, (std::vector<std::tuple<int, int, int, long, int>>{{0, 7, 1, 6, 1},
                                                                     {1, 7, 1, kFrames * 64 - 10, kFrames},
                                                                     {1, 9, 2, 10, 1},
                                                                     {2, 9, 2, kFrames * 100, kFrames},
                                                                     {3, 0, 0, kFrames * 24, kFrames}}));
  ASSERT_EQ(shares.size(), 5u);
  EXPECT_NEAR(shares[2].first, 10.0 / all, 1e-6);
  EXPECT_NEAR(shares[2].second, 10.0 / (kFrames * 64), 1e-6);
  EXPECT_NEAR(shares[0].second, 1.0, 1e-9);
}

TEST(Evaluate, DepthImagesLeaveUnmeasuredPixelsOut) {
  TempDir tmp;
  const auto bodies = scene_bodies();
  write_groundtruth(tmp.path() / "gt", bodies);
  // The sensor misses 12 pixels of object 1 in every frame; the tracker cannot label them.
  const Rect hole{2, 2, 5, 4};
  fs::create_directories(tmp.path() / "gt" / "depth");
  for (int t = 0; t < kFrames; ++t) {
    auto depth = blank();
    fill(depth, {0, 0, kWidth - 1, kHeight - 1}, 800);
    fill(depth, hole, 0);
    service::write_png16(frame_image(tmp.path() / "gt" / "depth", t).string(), depth);
  }
  RunSpec spec{{{1, 1}, {2, 2}, {3, 3}}};
  spec.edit_labels = [&](int, service::Image16& labels) { fill(labels, hole, 0); };
  write_run(tmp.path() / "run", bodies, spec);
  const auto gt = load_groundtruth(tmp.path() / "gt");
  const auto masked = evaluate_run("masked", tmp.path() / "run", gt, {});
  EXPECT_DOUBLE_EQ(masked.accuracy, 1.0);
  EXPECT_EQ(masked.points, static_cast<std::size_t>(kFrames * (64 + 100 + 24 - hole.area())));
  EXPECT_EQ(masked.depth_mask, (tmp.path() / "gt" / "depth").string());

  // Without depth images the same pixels count, as wrong.
  fs::remove_all(tmp.path() / "gt" / "depth");
  const auto unmasked = evaluate_run("unmasked", tmp.path() / "run", gt, {});
  EXPECT_EQ(unmasked.points, static_cast<std::size_t>(kFrames * (64 + 100 + 24)));
  EXPECT_NEAR(unmasked.accuracy, 1.0 - static_cast<double>(hole.area()) / 188.0, 1e-12);
}

TEST(Evaluate, ScenePointAccuracyLeavesPixelsPreprocessingRemovedOut) {
  TempDir tmp;
  const auto bodies = scene_bodies();
  write_groundtruth(tmp.path() / "gt", bodies);
  // Preprocessing dropped 12 pixels of object 1 (say, its bottom inside the table margin).
  const Rect removed{2, 2, 5, 4};
  RunSpec spec{{{1, 1}, {2, 2}, {3, 3}}};
  spec.edit_labels = [&](int, service::Image16& labels) { fill(labels, removed, service::kNotScenePoint); };
  write_run(tmp.path() / "run", bodies, spec);
  const auto run = evaluate_run("run", tmp.path() / "run", load_groundtruth(tmp.path() / "gt"), {});
  EXPECT_DOUBLE_EQ(run.accuracy, 1.0);
  EXPECT_EQ(run.points, static_cast<std::size_t>(kFrames * (64 + 100 + 24 - removed.area())));
  EXPECT_EQ(run.pixels, static_cast<std::size_t>(kFrames * (64 + 100 + 24)));
  EXPECT_NEAR(run.pixel_accuracy, 1.0 - static_cast<double>(removed.area()) / 188.0, 1e-12);
  EXPECT_EQ(run.mapping.count(static_cast<std::int32_t>(service::kNotScenePoint)), 0u);
}

TEST(Evaluate, DenseLabelsMarkMeasuredPixelsOutsideTheScene) {
  // 4x1 image at 1 m: pixel 0 unmeasured, 1 in a labelled scene voxel, 2 in an unlabelled one,
  // 3 measured but its voxel is not in the scene.
  const float f = 100.f;
  const std::vector<std::uint16_t> depth = {0, 1000, 1000, 1000};
  const auto at_pixel = [&](int u) { return Eigen::Vector3f((static_cast<float>(u) - 0.f) / f, 0.f, 1.f); };
  const std::vector<Eigen::Vector3f> scene = {at_pixel(1), at_pixel(2)};
  const std::vector<std::int32_t> labels = {7, 0};
  const VoxelGrid grid{.leaf = 0.005f, .corner = Eigen::Vector3f::Zero()};
  const auto image = service::dense_labels(4, 1, f, f, 0.f, 0.f, depth, grid, scene, labels);
  EXPECT_EQ(image.pixels, (std::vector<std::uint16_t>{0, 7, 0, service::kNotScenePoint}));
}

TEST(Evaluate, DenseLabelsFollowTheFramesVoxelGrid) {
  // 4x1 image at 1 m, pixels 1-3 at x = 1.25, 3.75 and 6.25 mm; one scene point at x = 3 mm. On the grid at the
  // origin the point's 5 mm voxel holds pixels 1 and 2; moved by 2.5 mm (a jittered frame), pixels 2 and 3.
  const float f = 400.f;
  const float cx = 0.5f;
  const std::vector<std::uint16_t> depth = {0, 1000, 1000, 1000};
  const std::vector<Eigen::Vector3f> scene = {Eigen::Vector3f(0.003f, 0.001f, 1.001f)};
  const std::vector<std::int32_t> labels = {7};
  const std::uint16_t none = service::kNotScenePoint;
  const auto grid_at = [](const Eigen::Vector3f& corner) { return VoxelGrid{.leaf = 0.005f, .corner = corner}; };
  EXPECT_EQ(service::dense_labels(4, 1, f, f, cx, 0.f, depth, grid_at(Eigen::Vector3f::Zero()), scene, labels).pixels,
            (std::vector<std::uint16_t>{0, 7, 7, none}));
  EXPECT_EQ(
      service::dense_labels(4, 1, f, f, cx, 0.f, depth, grid_at(Eigen::Vector3f(0.0025f, 0.f, 0.f)), scene, labels)
          .pixels,
      (std::vector<std::uint16_t>{0, none, 7, 7}));
  EXPECT_THROW(
      service::dense_labels(4, 1, f, f, cx, 0.f, depth, grid_at(Eigen::Vector3f(NAN, 0.f, 0.f)), scene, labels),
      std::invalid_argument);
}

TEST(Evaluate, FittingAndTimingAreSummarised) {
  TempDir tmp;
  const auto bodies = scene_bodies();
  write_groundtruth(tmp.path() / "gt", bodies);
  write_run(tmp.path() / "run", bodies, RunSpec{{{1, 1}, {2, 2}, {3, 3}}});
  {
    std::ofstream fit(tmp.path() / "run" / "fitting.csv");
    fit << "frame,object_id,fitting_distance_m\n0,1,0.002\n0,2,0.004\n1,1,0.001\n";
    std::ofstream timing(tmp.path() / "run" / "timing.csv");
    timing << "frame,total_ms\n0,10\n1,30\n2,20\n3,40\n";
  }
  const auto run = evaluate_run("fit", tmp.path() / "run", load_groundtruth(tmp.path() / "gt"), {});
  ASSERT_TRUE(run.has_fitting);
  EXPECT_NEAR(run.fitting_mean_m, (0.003 + 0.001) / 2.0, 1e-12);
  EXPECT_NEAR(run.frames.at(0).fitting_mean_m, 0.003, 1e-12);
  EXPECT_FALSE(run.frames.at(2).has_fitting);
  ASSERT_EQ(run.timing.size(), 1u);
  EXPECT_EQ(run.timing[0].name, "total_ms");
  EXPECT_DOUBLE_EQ(run.timing[0].mean, 25.0);
  EXPECT_DOUBLE_EQ(run.timing[0].median, 25.0);
  EXPECT_DOUBLE_EQ(run.timing[0].p95, 40.0);
  EXPECT_DOUBLE_EQ(run.timing[0].max, 40.0);
}

TEST(Evaluate, ReportFilesAreWritten) {
  TempDir tmp;
  const auto bodies = scene_bodies();
  write_groundtruth(tmp.path() / "gt", bodies);
  write_run(tmp.path() / "run", bodies, RunSpec{{{1, 4}, {2, 5}}});
  const auto gt = load_groundtruth(tmp.path() / "gt");
  const std::vector<RunResult> runs{evaluate_run("a", tmp.path() / "run", gt, {})};
  const fs::path out = tmp.path() / "out";
  fs::create_directories(out);
  write_run_tables(out, runs[0]);
  write_summary_json(out / "summary.json", runs, {});
  write_plot_spec(out / "plots.json", out, runs, gt, {spread_segmented_frames(runs[0], 3)}, {});
  std::ifstream summary(out / "summary.json");
  const std::string text((std::istreambuf_iterator<char>(summary)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\"tracks_lost\": 1"), std::string::npos) << text;
  EXPECT_NE(text.find("\"4\": 1"), std::string::npos) << text;
  std::ifstream frames(out / "a_frames.csv");
  std::string header;
  std::getline(frames, header);
  EXPECT_EQ(header, "frame,segmented,points,accuracy,fitting_mean_m,predicted_objects");
  int rows = 0;
  for (std::string line; std::getline(frames, line);) ++rows;
  EXPECT_EQ(rows, kFrames);
  EXPECT_EQ(spread_segmented_frames(runs[0], 3), (std::vector<std::int64_t>{0, 4, 9}));
}

// ---- bad inputs -------------------------------------------------------------------------------

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const EvaluationError& e) {
    return e.what();
  }
  return "(no error)";
}

class EvaluateBadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    write_groundtruth(tmp_.path() / "gt", scene_bodies());
    write_run(tmp_.path() / "run", scene_bodies(), RunSpec{{{1, 1}, {2, 2}, {3, 3}}});
  }
  void write_poses(const std::string& text) { std::ofstream(tmp_.path() / "run" / "poses.csv") << text; }
  std::string evaluate() {
    return error_of([&] { evaluate_run("r", tmp_.path() / "run", load_groundtruth(tmp_.path() / "gt"), {}); });
  }
  TempDir tmp_;
};

TEST_F(EvaluateBadInput, MissingFileIsNamed) {
  fs::remove(tmp_.path() / "run" / "poses.csv");
  const auto message = evaluate();
  EXPECT_NE(message.find((tmp_.path() / "run" / "poses.csv").string()), std::string::npos) << message;
  EXPECT_NE(message.find("cannot open"), std::string::npos) << message;
}

TEST_F(EvaluateBadInput, MissingLabelDirectoryIsNamed) {
  fs::remove_all(tmp_.path() / "gt" / "labels");
  const auto message = evaluate();
  EXPECT_NE(message.find((tmp_.path() / "gt" / "labels").string()), std::string::npos) << message;
}

TEST_F(EvaluateBadInput, WrongFieldCountNamesFileAndLine) {
  write_poses(
      "frame,utime,object_id,x,y,z,qx,qy,qz,qw,confidence,stale\n"
      "0,1,1,0,0,1,0,0,0,1,0.9,0\n"
      "1,2,1,0,0,1,0,0,0,1,0.9\n");
  const auto message = evaluate();
  EXPECT_NE(message.find("poses.csv:3: expected 12 fields, got 11"), std::string::npos) << message;
}

TEST_F(EvaluateBadInput, NonNumberNamesFileLineAndColumn) {
  write_poses(
      "frame,utime,object_id,x,y,z,qx,qy,qz,qw,confidence,stale\n"
      "# comment lines and blank lines keep their line numbers\n"
      "\n"
      "0,1,1,abc,0,1,0,0,0,1,0.9,0\n");
  const auto message = evaluate();
  EXPECT_NE(message.find("poses.csv:4: column 'x': 'abc'"), std::string::npos) << message;
}

TEST_F(EvaluateBadInput, MissingColumnIsNamed) {
  write_poses("frame,utime,object_id,x,y,z,qx,qy,qz,qw,stale\n0,1,1,0,0,1,0,0,0,1,0\n");
  const auto message = evaluate();
  EXPECT_NE(message.find("missing column 'confidence'"), std::string::npos) << message;
}

TEST_F(EvaluateBadInput, NonUnitQuaternionAndDuplicatesAreRefused) {
  write_poses("frame,utime,object_id,x,y,z,qx,qy,qz,qw,confidence,stale\n0,1,1,0,0,1,0,0,0,0,0.9,0\n");
  EXPECT_NE(evaluate().find("poses.csv:2: quaternion"), std::string::npos);
  write_poses(
      "frame,utime,object_id,x,y,z,qx,qy,qz,qw,confidence,stale\n"
      "0,1,1,0,0,1,0,0,0,1,0.9,0\n0,1,1,0,0,1,0,0,0,1,0.9,0\n");
  EXPECT_NE(evaluate().find("poses.csv:3: object 1 appears twice in frame 0"), std::string::npos);
}

TEST_F(EvaluateBadInput, LabelImagesOfDifferentSizesAreNamed) {
  service::Image16 small;
  small.width = 8;
  small.height = 8;
  small.pixels.assign(64, 0);
  const fs::path path = frame_image(tmp_.path() / "run" / "labels", 3);
  service::write_png16(path.string(), small);
  const auto message = evaluate();
  EXPECT_NE(message.find(path.string() + " is 8x8 but "), std::string::npos) << message;
}

TEST_F(EvaluateBadInput, CorruptPngIsNamed) {
  const fs::path path = frame_image(tmp_.path() / "gt" / "labels", 2);
  std::ofstream(path, std::ios::binary) << "not a png";
  const auto message = evaluate();
  EXPECT_NE(message.find(path.string()), std::string::npos) << message;
}

TEST(EvaluateOptions, InvalidThresholdsAreRefused) {
  EvaluationOptions options;
  options.translation_threshold_mm = 0.0;
  EXPECT_THROW(options.validate(), std::invalid_argument);
  options = {};
  options.rotation_threshold_deg = 200.0;
  EXPECT_THROW(options.validate(), std::invalid_argument);
  EXPECT_THROW(check_run_name("../x"), EvaluationError);
  EXPECT_NO_THROW(check_run_name("jcsd-100_particles.v2"));
}

}  // namespace
