// Edge-case scenes through the real mfot-inprocess executable: each scene is rendered, written as
// a TUM RGB-D folder, run with capture.source tum, and judged by the poses.csv it writes.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "../core/preprocess_test_scene.hpp"
#include "mfot/service/tum_dataset.hpp"

namespace mfot::service {
namespace {
namespace fs = std::filesystem;

const std::string kInprocess = std::string(MFOT_BINARY_DIR) + "/services/inprocess/mfot-inprocess";

class TempFolder {
 public:
  TempFolder() {
    const auto* info = testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() /
            ("mfot_" + std::string(info->test_suite_name()) + "_" + info->name() + "_" + std::to_string(::getpid()));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  TempFolder(const TempFolder&) = delete;
  TempFolder& operator=(const TempFolder&) = delete;
  ~TempFolder() {
    std::error_code error;
    fs::remove_all(path_, error);
  }
  std::string str(const std::string& child) const { return (path_ / child).string(); }

 private:
  fs::path path_;
};

struct PoseRow {
  std::int64_t frame = 0;
  int id = 0;
  std::vector<double> values;  // x, y, z, qx, qy, qz, qw, confidence
  bool stale = false;
};

struct RunResult {
  int exit_code = -1;
  std::string output;          // stdout and stderr
  std::vector<PoseRow> poses;  // poses.csv rows
  std::int64_t frames = 0;     // frames the run reported
};

// Renders frames into a TUM folder.
class SceneWriter {
 public:
  explicit SceneWriter(const std::string& folder) : writer_(options(folder)) {}

  void write(const test_scene::Frame& rendered) {
    Frame frame;
    frame.capture_utime = 1'000'000 + 33'333 * static_cast<std::int64_t>(writer_.frames_written());
    frame.width = rendered.width;
    frame.height = rendered.height;
    frame.fx = rendered.intrinsics.fx;
    frame.fy = rendered.intrinsics.fy;
    frame.cx = rendered.intrinsics.cx;
    frame.cy = rendered.intrinsics.cy;
    frame.depth_mm = rendered.depth_mm;
    frame.color = rendered.color;
    writer_.write(frame);
  }

 private:
  static TumWriterOptions options(const std::string& folder) {
    TumWriterOptions o;
    o.folder = folder;
    o.write_groundtruth = false;
    return o;
  }
  TumDatasetWriter writer_;
};

// Runs mfot-inprocess on a TUM folder (CPU likelihood) and reads what it wrote.
RunResult run_inprocess(const TempFolder& temp, const std::string& folder) {
  const std::string config = temp.str("config.yaml");
  std::ofstream(config) << "capture:\n  source: tum\n  folder: " << folder << "\ntracker:\n  backend: cpu\n";
  const std::string out = temp.str("out");
  const std::string command = kInprocess + " --config " + config + " --out " + out + " 2>&1";
  RunResult result;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) return result;
  char buffer[4096];
  while (std::fgets(buffer, sizeof buffer, pipe) != nullptr) result.output += buffer;
  const int status = ::pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream csv(out + "/poses.csv");
  std::string line;
  std::getline(csv, line);  // header: frame,utime,object_id,x,y,z,qx,qy,qz,qw,confidence,stale
  while (std::getline(csv, line)) {
    std::istringstream fields(line);
    std::string cell;
    std::vector<std::string> cells;
    while (std::getline(fields, cell, ',')) cells.push_back(cell);
    if (cells.size() != 12) {
      ADD_FAILURE() << "poses.csv line '" << line << "'";
      continue;
    }
    PoseRow row;
    row.frame = std::stoll(cells[0]);
    row.id = std::stoi(cells[2]);
    for (int i = 3; i <= 10; ++i)
      row.values.push_back(std::strtod(cells[static_cast<std::size_t>(i)].c_str(), nullptr));
    row.stale = cells[11] == "1";
    result.poses.push_back(row);
  }
  const auto at = result.output.find(" frames in ");
  if (at != std::string::npos) {
    const auto start = result.output.rfind(' ', at - 1);
    result.frames = std::stoll(result.output.substr(start + 1, at - start - 1));
  }
  return result;
}

bool finite_row(const PoseRow& row) {
  for (const double v : row.values) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

test_scene::Box cube_at(float x, float y, Rgb8 color) {
  return test_scene::Box{{x - 0.025f, y - 0.025f, 0.f}, {x + 0.025f, y + 0.025f, 0.05f}, color};
}

test_scene::Frame blank_frame() {
  test_scene::Frame frame;
  frame.width = 640;
  frame.height = 480;
  frame.depth_mm.assign(640 * 480, 0);
  frame.color.assign(frame.depth_mm.size(), Rgb8{});
  return frame;
}

class InprocessEdge : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(kInprocess)) GTEST_FAIL() << kInprocess << " is not built";
  }
  TempFolder temp_;
};

TEST_F(InprocessEdge, EmptyTableGivesNoObject) {
  SceneWriter writer(temp_.str("tum"));
  test_scene::Camera camera;
  camera.depth_noise_mm = 1.f;
  for (int i = 0; i < 6; ++i) {
    camera.noise_seed = static_cast<std::uint64_t>(i + 1);
    writer.write(test_scene::render(test_scene::Scene{}, camera));
  }
  const RunResult run = run_inprocess(temp_, temp_.str("tum"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_EQ(run.frames, 6) << run.output;
  EXPECT_TRUE(run.poses.empty()) << "an object made from an empty table";
}

TEST_F(InprocessEdge, FramesWithoutDepthOrWithOnePixelGiveNoObject) {
  SceneWriter writer(temp_.str("tum"));
  test_scene::Frame one_pixel = blank_frame();
  one_pixel.depth_mm[240 * 640 + 320] = 800;
  one_pixel.color[240 * 640 + 320] = Rgb8{255, 0, 0};
  for (int i = 0; i < 3; ++i) writer.write(blank_frame());
  for (int i = 0; i < 3; ++i) writer.write(one_pixel);
  const RunResult run = run_inprocess(temp_, temp_.str("tum"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_EQ(run.frames, 6) << run.output;
  EXPECT_TRUE(run.poses.empty());
}

TEST_F(InprocessEdge, NonFiniteIntrinsicsAreRefusedWithTheFileNamed) {
  // Depth is integral on every path into the pipeline; the only way to NaN points is NaN
  // intrinsics, which the reader refuses before any frame is processed.
  SceneWriter writer(temp_.str("tum"));
  writer.write(test_scene::render(test_scene::Scene{}, test_scene::Camera{}));
  std::ofstream(temp_.str("tum/intrinsics.txt")) << "nan 570.3 319.5 239.5\n";
  const RunResult run = run_inprocess(temp_, temp_.str("tum"));
  EXPECT_NE(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("intrinsics.txt"), std::string::npos) << run.output;
  EXPECT_TRUE(run.poses.empty());
}

TEST_F(InprocessEdge, ObjectLeavingTheViewIsRetired) {
  SceneWriter writer(temp_.str("tum"));
  const test_scene::Camera camera;
  test_scene::Scene scene;
  scene.boxes.push_back(cube_at(0.f, 0.f, Rgb8{30, 180, 40}));
  scene.boxes.push_back(cube_at(0.30f, 0.f, Rgb8{200, 30, 30}));
  int left_view_at = -1;
  const int frames = 40;
  for (int i = 0; i < frames; ++i) {
    scene.boxes[1] = cube_at(0.30f + 0.015f * static_cast<float>(i), 0.f, Rgb8{200, 30, 30});
    const test_scene::Frame frame = test_scene::render(scene, camera);
    bool visible = false;
    for (std::size_t p = 0; p < frame.color.size() && !visible; ++p) {
      visible = frame.depth_mm[p] > 0 && frame.color[p].r == 200;
    }
    if (!visible && left_view_at < 0) left_view_at = i;
    writer.write(frame);
  }
  ASSERT_GE(left_view_at, 0);
  ASSERT_LT(left_view_at + 6, frames);
  const RunResult run = run_inprocess(temp_, temp_.str("tum"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  std::map<int, std::int64_t> last_frame;
  std::map<std::int64_t, int> rows_per_frame;
  for (const PoseRow& row : run.poses) {
    EXPECT_TRUE(finite_row(row)) << "object " << row.id << " frame " << row.frame;
    last_frame[row.id] = std::max(last_frame[row.id], row.frame);
    ++rows_per_frame[row.frame];
  }
  ASSERT_EQ(last_frame.size(), 2u) << "expected exactly the two cubes' ids";
  // One id (the static cube) lasts to the end, the other is retired at most 5 frames after its
  // cube has left the view.
  const auto [static_id, static_last] = *std::max_element(
      last_frame.begin(), last_frame.end(), [](const auto& a, const auto& b) { return a.second < b.second; });
  EXPECT_EQ(static_last, frames - 1);
  for (const auto& [id, last] : last_frame) {
    if (id != static_id) {
      EXPECT_LE(last, left_view_at + 5) << "object " << id << " outlived its cube";
    }
  }
  EXPECT_EQ(rows_per_frame.at(frames - 1), 1);
}

TEST_F(InprocessEdge, TwentyObjectsGetTwentyDistinctIds) {
  SceneWriter writer(temp_.str("tum"));
  test_scene::Scene scene;
  const Rgb8 palette[5] = {{200, 30, 30}, {30, 180, 40}, {30, 60, 200}, {220, 200, 40}, {180, 40, 180}};
  for (int row = 0; row < 4; ++row) {
    for (int col = 0; col < 5; ++col) {
      scene.boxes.push_back(cube_at(-0.24f + 0.12f * static_cast<float>(col), -0.18f + 0.12f * static_cast<float>(row),
                                    palette[(row + col) % 5]));
    }
  }
  test_scene::Camera camera;
  camera.depth_noise_mm = 1.f;
  const int frames = 5;
  for (int i = 0; i < frames; ++i) {
    camera.noise_seed = static_cast<std::uint64_t>(i + 1);
    writer.write(test_scene::render(scene, camera));
  }
  const RunResult run = run_inprocess(temp_, temp_.str("tum"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  std::map<std::int64_t, std::set<int>> ids_per_frame;
  std::set<int> all_ids;
  for (const PoseRow& row : run.poses) {
    EXPECT_TRUE(finite_row(row)) << "object " << row.id << " frame " << row.frame;
    EXPECT_TRUE(ids_per_frame[row.frame].insert(row.id).second) << "id " << row.id << " twice in frame " << row.frame;
    all_ids.insert(row.id);
  }
  ASSERT_EQ(ids_per_frame.size(), static_cast<std::size_t>(frames));
  for (const auto& [frame, ids] : ids_per_frame) EXPECT_EQ(ids.size(), 20u) << "frame " << frame;
  EXPECT_EQ(all_ids.size(), 20u);
}

}  // namespace
}  // namespace mfot::service
