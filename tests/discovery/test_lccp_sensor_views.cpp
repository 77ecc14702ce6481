// LCCP discovery on the simulator's noisy sensor views (Kinect-like depth noise, frayed edges), through the
// Preprocessor: where `apart`'s low box touches the tall box, its front face 1 cm behind the tall box's, a
// 3 cm supervoxel straddles the step and LCCP reads the connection as smooth; 2 cm supervoxels (the shipped
// merger.discovery.seed_resolution) find it more often, most of all where 3 cm almost never does.
#include <gtest/gtest.h>

#include <map>
#include <vector>

#include "mfot/object_discovery.hpp"
#include "mfot/preprocessing.hpp"
#include "mfot/sim/simulator.hpp"

namespace mfot {
namespace {

constexpr int kTallBox = 3;  // `apart`'s ground-truth ids
constexpr int kLowBox = 4;

// The points of the scene's cluster that holds the low box, each with its ground-truth label.
struct TwoBoxCluster {
  std::vector<Eigen::Vector3f> positions;
  std::vector<Rgb8> colors;
  std::vector<int> truth;
};

TwoBoxCluster low_box_cluster(const sim::RenderedFrame& frame, const SceneCloud& scene) {
  std::vector<int> truth(scene.size());
  std::map<int, int> low_box_points;  // cluster -> points
  for (std::size_t i = 0; i < scene.size(); ++i) {
    truth[i] = frame.labels[static_cast<std::size_t>(scene.pixel_v[i]) * frame.intrinsics.width + scene.pixel_u[i]];
    if (truth[i] == kLowBox && scene.cluster[i] >= 0) ++low_box_points[scene.cluster[i]];
  }
  int cluster = -1, most = 0;
  for (const auto& [c, n] : low_box_points) {
    if (n > most) most = n, cluster = c;
  }
  TwoBoxCluster out;
  for (std::size_t i = 0; i < scene.size(); ++i) {
    if (scene.cluster[i] != cluster) continue;
    out.positions.push_back(scene.positions[i]);
    out.colors.push_back(scene.colors[i]);
    out.truth.push_back(truth[i]);
  }
  return out;
}

// Whether the parts tell the two boxes apart: the part holding most of each box's points holds at least 90 % of
// them, and the two parts differ.
bool boxes_apart(const TwoBoxCluster& cluster, const std::vector<int>& part) {
  std::map<int, std::map<int, int>> count;  // box -> part -> points
  for (std::size_t i = 0; i < part.size(); ++i) ++count[cluster.truth[i]][part[i]];
  int main_part[2] = {-1, -1};
  for (int b = 0; b < 2; ++b) {
    int best = 0, total = 0;
    for (const auto& [p, n] : count[b == 0 ? kTallBox : kLowBox]) {
      total += n;
      if (n > best) best = n, main_part[b] = p;
    }
    if (total == 0 || best < 0.9 * total) return false;
  }
  return main_part[0] != main_part[1];
}

// Frames (of the first `frames`) in which the discovery tells the low box from the tall box, for each sensor-noise
// seed given.
std::vector<int> frames_apart(float seed_resolution, const std::vector<std::uint64_t>& seeds, int frames) {
  DiscoveryOptions options;
  options.method = DiscoveryMethod::kLccp;
  options.seed_resolution = seed_resolution;
  const auto discovery = make_object_discovery(options);
  std::vector<int> apart;
  for (const std::uint64_t seed : seeds) {
    sim::SimulatorOptions sim_options;
    sim_options.scenario.name = "apart";
    sim_options.scenario.seed = seed;
    const sim::Simulator simulator(sim_options);
    Preprocessor preprocessor{PreprocessorOptions{}};
    int count = 0;
    std::vector<int> part;
    for (int f = 0; f < frames; ++f) {
      const sim::RenderedFrame frame = simulator.render(f);
      preprocessor.process(sim::image_view(frame));
      const TwoBoxCluster cluster = low_box_cluster(frame, preprocessor.scene());
      discovery->split(cluster.positions, cluster.colors, part);
      count += boxes_apart(cluster, part) ? 1 : 0;
    }
    apart.push_back(count);
  }
  return apart;
}

TEST(LccpDiscoveryOnSensorViews, TwoCentimetreSupervoxelsFindTheStepBetweenTouchingFrontFaces) {
  // The sensor-noise seeds (of the seed matrix's learn seeds 21-80, 154) whose first frames the discovery split into
  // the two boxes in at most 2 of 16 frames with 3 cm supervoxels: too few for the confirmation's 3 votes, so the two
  // boxes stayed one object (67, 154). Over seeds 21-80 the boxes come apart in 5.6 (3 cm) and 6.4 (2 cm) of 16
  // frames on average: the cluster's own points, before any model shapes them.
  const std::vector<std::uint64_t> seeds = {27, 41, 67, 154};
  constexpr int kFrames = 16;  // the confirmation's frames (merger.discovery.confirm_frames 15) and the birth's
  const std::vector<int> coarse = frames_apart(0.03f, seeds, kFrames);
  const std::vector<int> fine = frames_apart(0.02f, seeds, kFrames);
  for (std::size_t k = 0; k < seeds.size(); ++k) {
    SCOPED_TRACE(testing::Message() << "seed " << seeds[k] << ": apart in " << coarse[k] << " (3 cm) and " << fine[k]
                                    << " (2 cm) of " << kFrames << " frames");
    EXPECT_GT(fine[k], coarse[k]);
    EXPECT_GE(fine[k], kFrames / 4);
  }
}

}  // namespace
}  // namespace mfot
