// Preprocessing speed per stage on 640x480 simulator frames (scenario "stack", with sensor
// noise and hands), on `threads` threads (PreprocessorOptions::threads; the scene is the same for
// any count). Target: at most 10 ms per frame in total on one core. Stage times are wall clock
// (steady clock); on a busy machine compare the CPU time of the whole call (all threads).
// With PCL, also compares the voxel stage with pcl::VoxelGrid on the same points.
//
// Usage: bench_preprocess [repetitions=10] [threads=1]

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>
#include <vector>

#include "bench_timing.hpp"
#include "mfot/preprocessing.hpp"
#include "mfot/sim/simulator.hpp"

#if MFOT_BENCH_PCL
#include "bench_preprocess_pcl.hpp"
#endif

namespace {

using mfot::bench::Clock;
using mfot::bench::ms_since;
using mfot::bench::Series;

void print_row(const char* name, const Series& s) {
  std::printf("  %-28s mean %7.3f ms   median %7.3f ms   p95 %7.3f ms\n", name, s.mean(), s.percentile(0.5),
              s.percentile(0.95));
}

// The points the voxel stage sees: back-projected, cropped and above the plane (as Preprocessor).
void kept_points(const mfot::sim::RenderedFrame& f, const mfot::PreprocessorOptions& options,
                 const mfot::TablePlane& plane, std::vector<Eigen::Vector3f>& positions,
                 std::vector<mfot::Rgb8>& colors, std::vector<std::uint32_t>& ids, bool above_plane_only) {
  positions.clear();
  colors.clear();
  ids.clear();
  const auto& k = f.intrinsics;
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const std::size_t i = static_cast<std::size_t>(v * k.width + u);
      if (f.depth_mm[i] == 0) continue;
      const float z = static_cast<float>(f.depth_mm[i]) * 0.001f;
      const Eigen::Vector3f p((static_cast<float>(u) - k.cx) / k.fx * z, (static_cast<float>(v) - k.cy) / k.fy * z, z);
      if ((p.array() < options.crop_min.array()).any() || (p.array() > options.crop_max.array()).any()) continue;
      if (above_plane_only && plane.valid && !(plane.signed_distance(p) > options.plane_margin)) continue;
      positions.push_back(p);
      colors.push_back(f.color[i]);
      ids.push_back(static_cast<std::uint32_t>(i));
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  const int repetitions = argc > 1 ? std::max(1, std::atoi(argv[1])) : 10;
  const int threads = argc > 2 ? std::atoi(argv[2]) : 1;
  if (threads < 1 || threads > 64) {
    std::fprintf(stderr, "bench_preprocess: threads must be in [1, 64], got %s\n", argv[2]);
    return 2;
  }

  mfot::sim::SimulatorOptions sim_options;
  sim_options.scenario.name = "stack";
  const mfot::sim::Simulator simulator(sim_options);
  constexpr int kFrames = 24;
  std::vector<mfot::sim::RenderedFrame> frames;
  for (int i = 0; i < kFrames; ++i)
    frames.push_back(simulator.render(i * (simulator.num_frames() - 1) / (kFrames - 1)));
  const auto& k = frames.front().intrinsics;
  std::printf("bench_preprocess: %d x %d frames, %d frames of sim 'stack' x %d repetitions, %d thread%s\n", k.width,
              k.height, kFrames, repetitions, threads, threads == 1 ? "" : "s");

  mfot::PreprocessorOptions options;
  options.threads = threads;
  // Steady state: the plane is kept between frames (refitted only when it stops fitting).
  {
    mfot::Preprocessor preprocessor(options);
    for (const auto& f : frames) preprocessor.process(mfot::sim::image_view(f));  // warm-up
    Series backproject, plane, voxel, cluster, total, wall, cpu;
    Series cropped, above, voxels, clusters;
    int refits = 0;
    for (int r = 0; r < repetitions; ++r) {
      for (const auto& f : frames) {
        const auto start = Clock::now();
        const std::clock_t cpu_start = std::clock();
        const mfot::SceneCloud& scene = preprocessor.process(mfot::sim::image_view(f));
        cpu.add(1000.0 * static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC);
        wall.add(ms_since(start));
        const auto& s = preprocessor.stats();
        backproject.add(s.backproject_ms);
        plane.add(s.plane_ms);
        voxel.add(s.voxel_ms);
        cluster.add(s.cluster_ms);
        total.add(s.total_ms);
        cropped.add(static_cast<double>(s.cropped));
        above.add(static_cast<double>(s.above_plane));
        voxels.add(static_cast<double>(s.voxels));
        clusters.add(scene.num_clusters);
        refits += s.plane_refitted ? 1 : 0;
      }
    }
    std::printf("steady state (plane kept; %d refits in %zu frames):\n", refits, total.values.size());
    print_row("1+2 back-project + crop", backproject);
    print_row("3   table removal", plane);
    print_row("4   voxel 5 mm + pixel map", voxel);
    print_row("5   Euclidean clustering", cluster);
    print_row("    total (stages)", total);
    print_row("    total (process call)", wall);
    print_row("    CPU time (process call)", cpu);
    std::printf("  ms per frame (process call, %d thread%s): mean %.3f, median %.3f\n", threads,
                threads == 1 ? "" : "s", wall.mean(), wall.percentile(0.5));
    std::printf("  points: cropped %.0f, above plane %.0f, voxels %.0f, clusters %.1f (means)\n", cropped.mean(),
                above.mean(), voxels.mean(), clusters.mean());
  }
  // Worst case: a RANSAC refit every frame.
  {
    mfot::Preprocessor preprocessor(options);
    Series plane, total;
    for (int r = 0; r < repetitions; ++r) {
      for (const auto& f : frames) {
        preprocessor.reset_plane();
        preprocessor.process(mfot::sim::image_view(f));
        plane.add(preprocessor.stats().plane_ms);
        total.add(preprocessor.stats().total_ms);
      }
    }
    std::printf("refit every frame (RANSAC %d iterations on %d samples + refinement):\n", options.plane_fit.iterations,
                options.plane_fit.sample_points);
    print_row("3   table removal", plane);
    print_row("    total (stages)", total);
  }

  // Voxel grid alone: ours against pcl::VoxelGrid on the same points.
  mfot::Preprocessor reference(options);
  reference.process(mfot::sim::image_view(frames.front()));
  const mfot::TablePlane table = reference.plane();
  for (const bool above_only : {true, false}) {
    mfot::VoxelDownsampler ours(options.voxel_size);
    std::vector<Eigen::Vector3f> positions;
    std::vector<mfot::Rgb8> colors;
    std::vector<std::uint32_t> ids;
    Series ours_ms;
    double points = 0.0, ours_voxels = 0.0;
#if MFOT_BENCH_PCL
    Series pcl_ms;
    double pcl_voxels = 0.0;
#endif
    for (const auto& f : frames) {
      kept_points(f, options, table, positions, colors, ids, above_only);
      points += static_cast<double>(positions.size());
      ours.downsample(positions, colors, ids);  // warm-up
      for (int r = 0; r < repetitions; ++r) {
        const auto start = Clock::now();
        ours_voxels += static_cast<double>(ours.downsample(positions, colors, ids));
        ours_ms.add(ms_since(start));
      }
#if MFOT_BENCH_PCL
      std::vector<float> xyz;
      std::vector<std::uint8_t> rgb;
      for (std::size_t i = 0; i < positions.size(); ++i) {
        xyz.insert(xyz.end(), {positions[i].x(), positions[i].y(), positions[i].z()});
        rgb.insert(rgb.end(), {colors[i].r, colors[i].g, colors[i].b});
      }
      const auto pcl_result = mfot::bench::pcl_voxel_grid(xyz, rgb, options.voxel_size, repetitions);
      for (const double ms : pcl_result.filter_ms) pcl_ms.add(ms);
      pcl_voxels += static_cast<double>(pcl_result.voxels) * repetitions;
#endif
    }
    const double runs = static_cast<double>(frames.size()) * repetitions;
    std::printf("voxel grid 5 mm on %s (mean %.0f points):\n",
                above_only ? "the above-plane points" : "all cropped points",
                points / static_cast<double>(frames.size()));
    print_row("mfot::VoxelDownsampler", ours_ms);
    std::printf("  %-28s mean %.0f voxels\n", "", ours_voxels / runs);
#if MFOT_BENCH_PCL
    print_row("pcl::VoxelGrid", pcl_ms);
    std::printf("  %-28s mean %.0f voxels\n", "", pcl_voxels / runs);
    std::printf("  speed-up %.1fx (means)\n", pcl_ms.mean() / std::max(ours_ms.mean(), 1e-9));
#else
    std::printf("  pcl::VoxelGrid: not built (PCL is found only with MFOT_SERVICES=ON)\n");
#endif
  }
  return 0;
}
