// RunOutputs' fitting.csv (thesis eq. 4.1, 4.2): each object's distance computed side by side on the
// output thread's pool is what the evaluator gives it alone, and the file is the same for any thread count.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "mfot/metrics.hpp"
#include "mfot/service/run_outputs.hpp"

namespace mfot::service {
namespace {

namespace fs = std::filesystem;

// A scene of six boxes' top faces (camera frame) and their objects: models a little off the points.
struct Frames {
  Scene scene;
  std::map<std::int32_t, ManagedObject> objects;
};
Frames six_objects(int frame) {
  Frames f;
  f.scene.frame_seq = frame;
  for (int k = 0; k < 6; ++k) {
    const Eigen::Vector3f centre(-0.25f + 0.1f * static_cast<float>(k), 0.f, 0.8f + 0.01f * static_cast<float>(frame));
    ManagedObject object;
    object.id = k + 1;
    object.pose.translation = centre + Eigen::Vector3f(0.002f * static_cast<float>(k + 1), 0.f, 0.f);
    for (int i = 0; i < 12; ++i) {
      for (int j = 0; j < 12; ++j) {
        const Eigen::Vector3f p(-0.03f + 0.005f * static_cast<float>(i), -0.03f + 0.005f * static_cast<float>(j), 0.f);
        f.scene.cloud.push_back(centre + p, Rgb8{100, 100, 100});
        object.model.cloud.push_back(p, Rgb8{100, 100, 100});
      }
    }
    f.objects.emplace(object.id, std::move(object));
  }
  f.scene.cluster.assign(f.scene.cloud.size(), 0);
  return f;
}

std::string fitting_csv(int threads) {
  const fs::path dir =
      fs::temp_directory_path() / ("mfot_run_outputs_" + std::to_string(::getpid()) + "_" + std::to_string(threads));
  fs::remove_all(dir);
  MalformedCounter malformed;
  {
    RunOutputs outputs(
        dir.string(), false,
        RunOutputsOptions{.write_labels = false, .fitting_distance = true, .background = true, .threads = threads},
        malformed);
    for (int frame = 0; frame < 3; ++frame) {
      const Frames f = six_objects(frame);
      const std::vector<std::int32_t> labels(f.scene.cloud.size(), 1);
      outputs.write_frame(f.scene, labels, f.objects, std::nullopt);
    }
    outputs.finish();
  }
  std::ifstream in(dir / "fitting.csv");
  std::stringstream text;
  text << in.rdbuf();
  fs::remove_all(dir);
  return text.str();
}

TEST(RunOutputs, FittingDistancesSideBySideAreEachObjectsAlone) {
  const std::string one = fitting_csv(1);
  EXPECT_EQ(fitting_csv(4), one);
  // Every row is the evaluator's distance of that object alone.
  std::istringstream rows(one);
  std::string line;
  std::getline(rows, line);  // header
  int checked = 0;
  while (std::getline(rows, line)) {
    std::istringstream row(line);
    std::string frame, id, distance;
    std::getline(row, frame, ',');
    std::getline(row, id, ',');
    std::getline(row, distance, ',');
    const Frames f = six_objects(std::stoi(frame));
    FittingDistanceEvaluator evaluator;
    evaluator.set_scene(f.scene.cloud.positions);
    const ManagedObject& object = f.objects.at(std::stoi(id));
    const double alone = evaluator.evaluate(object.model.cloud.positions, object.pose).mean;
    EXPECT_NEAR(std::stod(distance), alone, 5e-6 * alone) << line;  // the file keeps 6 digits
    EXPECT_GT(alone, 0.0);                                          // the models lie off the points: a real distance
    ++checked;
  }
  EXPECT_EQ(checked, 18);
}

TEST(RunOutputs, RefusesAThreadCountOutOfRange) {
  MalformedCounter malformed;
  const fs::path dir = fs::temp_directory_path() / ("mfot_run_outputs_bad_" + std::to_string(::getpid()));
  EXPECT_THROW(RunOutputs(dir.string(), false, RunOutputsOptions{.threads = 65}, malformed), std::invalid_argument);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mfot::service
