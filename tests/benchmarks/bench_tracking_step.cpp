// Cost of one object's tracking step on the CPU (issue 17's budget: at most 1.5x the thesis's step
// for 3 objects at 100 particles): the particle filter's step alone, the published confidence
// (EstimateFit) on the same points, and the whole TrackingStep with and without the motion-model
// options (pattern-search refinement, the isolated-object step of configs/default.yaml: a
// quarter more particles moved by dX and 2 refinement rounds while no other object is near, and the ICP
// refinement: 10 iterations on up to 2000 points as configured, 5 on 200 as before, or 10 whose last 3
// take 2000). The object is the synthetic 10 x 15 x 8 cm test box (~1500 model points at 5 mm)
// turning 3 degrees and moving 5 mm a frame, seen with its near side and a flat patch beside it in the
// hypothesis margin. Every figure is the median over the
// frames of a run.
//
// Usage: mfot_bench_tracking_step [--frames N]

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "../core/synthetic_object.hpp"
#include "bench_timing.hpp"
#include "mfot/estimate_fit.hpp"
#include "mfot/hypothesis.hpp"
#include "mfot/jcsd_likelihood.hpp"
#include "mfot/particle_filter.hpp"
#include "mfot/tracking_step.hpp"

namespace {

using mfot::bench::Clock;
using mfot::bench::ms_since;
using mfot::bench::Series;
namespace test = mfot::test;

const Eigen::Vector3f kSize(0.10f, 0.15f, 0.08f);

mfot::Pose pose_at(int frame) {
  return test::make_pose(Eigen::Vector3f(0.005f * static_cast<float>(frame) * 0.2f, 0.f, 0.9f),
                         Eigen::Vector3f(0.3f, 1.f, 0.2f), test::radians(3.f * static_cast<float>(frame)));
}

mfot::ColoredCloud scene_at(int frame) {
  mfot::ColoredCloud scene = test::seen_from_origin(test::make_test_object(0.5f, 0.005f, true), kSize, pose_at(frame));
  for (float x = 0.1f; x < 0.16f; x += 0.005f) {  // a patch beside the box, inside the margin
    for (float y = -0.05f; y < 0.05f; y += 0.005f) scene.push_back(Eigen::Vector3f(x, y, 0.92f), test::kWhite);
  }
  return scene;
}

struct Row {
  const char* name;
  mfot::ParticleFilterOptions filter;
  mfot::TrackingStepOptions step;
};

}  // namespace

int main(int argc, char** argv) {
  int frames = 200;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--frames") == 0 && i + 1 < argc) {
      frames = std::atoi(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: mfot_bench_tracking_step [--frames N]\n");
      return 2;
    }
  }
  if (frames < 2) {
    std::fprintf(stderr, "--frames must be at least 2\n");
    return 2;
  }
  const mfot::ObjectModel model = test::make_model(test::make_test_object(0.f, 0.005f, true));
  const Eigen::AlignedBox3f box = mfot::model_bounding_box(model);
  std::vector<mfot::ColoredCloud> scenes;
  for (int f = 0; f <= frames; ++f) scenes.push_back(scene_at(f));

  mfot::ParticleFilterOptions thesis;
  thesis.num_particles = 100;
  mfot::TrackingStepOptions isolated;  // nothing else near: every frame steps with isolated_motion
  isolated.exclude_claimed_radius = 0.01f;
  isolated.isolated_motion = mfot::StepMotion{0.75f, 2};
  mfot::TrackingStepOptions isolated_icp = isolated;
  isolated_icp.icp.iterations = 5;
  isolated_icp.icp.min_paired_share = 0.8f;
  isolated_icp.icp.max_points = 200;
  mfot::TrackingStepOptions icp_only;  // the thesis's step refined (an object with a hand or neighbour near)
  icp_only.icp = isolated_icp.icp;
  // The services' refinement: 10 iterations on up to 2000 points.
  mfot::TrackingStepOptions dense_icp = icp_only;
  dense_icp.icp.iterations = 10;
  dense_icp.icp.max_points = 2000;
  mfot::TrackingStepOptions isolated_dense_icp = isolated;
  isolated_dense_icp.icp = dense_icp.icp;
  const Row rows[] = {{"thesis motion model", thesis, {}},
                      {"thesis motion model, ICP 5 on 200 points (others near)", thesis, icp_only},
                      {"thesis motion model, ICP 10 on 2000 points (others near)", thesis, dense_icp},
                      {"isolated: predicted 0.75, refine 2", thesis, isolated},
                      {"isolated: predicted 0.75, refine 2, ICP 5 on 200 points", thesis, isolated_icp},
                      {"isolated: predicted 0.75, refine 2, ICP 10 on 2000 points", thesis, isolated_dense_icp}};

  std::printf("model %zu points, 100 particles, %d frames (median ms per object and frame)\n\n", model.cloud.size(),
              frames);
  std::printf(
      "| motion model | hypothesis points | TrackingStep | of it: EstimateFit | share | frames ICP-refined "
      "|\n|---|---:|---:|---:|---:|---:|\n");
  for (const Row& row : rows) {
    mfot::JcsdLikelihood likelihood;
    likelihood.set_model(model);
    mfot::ParticleFilter filter(row.filter);
    filter.reset(pose_at(0));
    mfot::TrackingStep step(row.step);
    mfot::EstimateFit fit;
    Series total, confidence, points;
    int icp_refined = 0;
    for (int f = 1; f <= frames; ++f) {
      const auto t0 = Clock::now();
      const mfot::TrackingStepResult r =
          step.track(scenes[static_cast<std::size_t>(f)], model, box, filter, likelihood);
      total.add(ms_since(t0));
      const auto t1 = Clock::now();
      const float c = fit.fit(step.hypothesis(), model, box, r.estimate);
      confidence.add(ms_since(t1));
      points.add(static_cast<double>(r.hypothesis_points));
      if (!(c >= 0.f)) return 1;  // keeps the call
      if (r.isolated != (row.step.exclude_claimed_radius > 0.f)) return 1;
      icp_refined += r.icp_refined ? 1 : 0;
    }
    std::printf("| %s | %.0f | %.3f | %.3f | %.0f %% | %d |\n", row.name, points.median(), total.median(),
                confidence.median(), 100.0 * confidence.median() / total.median(), icp_refined);
  }
  return 0;
}
