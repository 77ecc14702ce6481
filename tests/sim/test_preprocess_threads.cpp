// The Preprocessor on the simulator's frames gives the same scene, bit for bit, for any thread
// count (fixed placement of the pieces' outputs, integer counts, an order-free union-find).

#include <gtest/gtest.h>

#include <vector>

#include "mfot/preprocessing.hpp"
#include "mfot/sim/simulator.hpp"

namespace mfot {
namespace {

void expect_same_scene(const Preprocessor& a, const Preprocessor& b, int frame) {
  const SceneCloud& x = a.scene();
  const SceneCloud& y = b.scene();
  ASSERT_EQ(x.size(), y.size()) << "frame " << frame;
  ASSERT_GT(x.size(), 1000u) << "frame " << frame << ": a real scene";
  EXPECT_EQ(x.num_clusters, y.num_clusters) << "frame " << frame;
  EXPECT_EQ(x.plane.coefficients, y.plane.coefficients) << "frame " << frame;
  for (std::size_t i = 0; i < x.size(); ++i) {
    ASSERT_EQ(x.positions[i], y.positions[i]) << "frame " << frame << " point " << i;
    ASSERT_EQ(x.colors[i], y.colors[i]) << "frame " << frame << " point " << i;
    ASSERT_EQ(x.pixel_u[i], y.pixel_u[i]) << "frame " << frame << " point " << i;
    ASSERT_EQ(x.pixel_v[i], y.pixel_v[i]) << "frame " << frame << " point " << i;
    ASSERT_EQ(x.cluster[i], y.cluster[i]) << "frame " << frame << " point " << i;
  }
  const PreprocessStats& s = a.stats();
  const PreprocessStats& t = b.stats();
  EXPECT_EQ(s.valid_depth, t.valid_depth);
  EXPECT_EQ(s.cropped, t.cropped);
  EXPECT_EQ(s.above_plane, t.above_plane);
  EXPECT_EQ(s.plane_inlier_share, t.plane_inlier_share);
  EXPECT_EQ(s.plane_refitted, t.plane_refitted);
  ASSERT_EQ(a.pixel_voxel_index().size(), b.pixel_voxel_index().size());
  for (std::size_t i = 0; i < a.pixel_voxel_index().size(); ++i) {
    ASSERT_EQ(a.pixel_voxel_index()[i], b.pixel_voxel_index()[i]) << "frame " << frame << " pixel " << i;
  }
}

TEST(PreprocessorThreads, SameSceneForOneTwoAndSevenThreads) {
  sim::SimulatorOptions sim_options;
  sim_options.scenario.name = "stack";  // sensor noise, a hand carrying and stacking objects
  const sim::Simulator simulator(sim_options);
  PreprocessorOptions options;
  Preprocessor one(options);
  options.threads = 2;
  Preprocessor two(options);
  options.threads = 7;
  Preprocessor seven(options);
  constexpr int kFrames = 8;
  for (int k = 0; k < kFrames; ++k) {
    const int frame = k * (simulator.num_frames() - 1) / (kFrames - 1);
    const sim::RenderedFrame rendered = simulator.render(frame);
    if (k == kFrames / 2) {  // a RANSAC refit in the middle of the sequence, too
      one.reset_plane();
      two.reset_plane();
      seven.reset_plane();
    }
    one.process(sim::image_view(rendered));
    two.process(sim::image_view(rendered));
    seven.process(sim::image_view(rendered));
    expect_same_scene(one, two, frame);
    expect_same_scene(one, seven, frame);
  }
}

TEST(PreprocessorThreads, ThreadCountIsValidated) {
  PreprocessorOptions options;
  options.threads = 0;
  EXPECT_THROW(options.validate(), std::invalid_argument);
  options.threads = 65;
  EXPECT_THROW(options.validate(), std::invalid_argument);
  options.threads = 64;
  EXPECT_NO_THROW(options.validate());
}

}  // namespace
}  // namespace mfot
