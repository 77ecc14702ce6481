// Thesis Table 4.1 (section 4.3): JCSD hypothesis evaluation time against the particle number for
// an object of about 900 points, CPU (one thread) against GPU, plus a 3-object frame
// (3 objects x 1000 particles x 2000 points). GPU columns: the scoring kernel alone (CUDA
// events), the device work of one call (uploads + kernel + download, CUDA events) and the wall
// time of one evaluate() call (packing, transfers, kernel, waiting). Every figure is the median of
// repeated calls that rotate over 4 particle sets. The largest CPU/GPU score difference of each row
// is printed as a parity check. Without CUDA (or without a device) the GPU columns read n/a.
//
// Usage: mfot_bench_likelihood [--csv FILE] [--quick] [--only PARTICLES]
//   --quick  fewer repetitions and no 5000-particle CPU row (for CI smoke runs)
//   --only   just the object row of that particle count (e.g. to profile one launch shape)

#include "bench_timing.hpp"
#include "mfot/cuda/likelihood_factory.hpp"
#include "mfot/jcsd_likelihood.hpp"

#if MFOT_HAVE_CUDA
#include "mfot/cuda/cuda_jcsd_likelihood.hpp"
#endif

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <memory>
#include <random>
#include <string>
#include <vector>

namespace {

using mfot::HypothesisData;
using mfot::ObjectModel;
using mfot::Pose;
using mfot::bench::Clock;

float uniform01(std::mt19937_64& rng) { return static_cast<float>(rng() >> 40) * 0x1.0p-24f; }

float gaussian(std::mt19937_64& rng) {
  const float u1 = std::max(uniform01(rng), 1e-7f);
  return std::sqrt(-2.f * std::log(u1)) * std::cos(6.2831853f * uniform01(rng));
}

// An object as the camera sees it after 5 mm voxel filtering: the three visible faces of a box,
// sampled on a `step` lattice, each face in two colours (a printed pattern of stripes).
ObjectModel make_box_model(const Eigen::Vector3f& size, float step, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const mfot::Rgb8 palette[6] = {{200, 30, 40},  {240, 220, 200}, {30, 90, 200},
                                 {250, 200, 30}, {40, 160, 60},   {20, 20, 25}};
  ObjectModel model;
  const Eigen::Vector3f half = size / 2.f;
  for (int face = 0; face < 3; ++face) {
    const int u_axis = (face + 1) % 3;
    const int v_axis = (face + 2) % 3;
    const int nu = static_cast<int>(size[u_axis] / step);
    const int nv = static_cast<int>(size[v_axis] / step);
    for (int i = 0; i < nu; ++i) {
      for (int j = 0; j < nv; ++j) {
        Eigen::Vector3f p;
        p[face] = -half[face];
        p[u_axis] = -half[u_axis] + (static_cast<float>(i) + 0.5f) * step;
        p[v_axis] = -half[v_axis] + (static_cast<float>(j) + 0.5f) * step;
        const int colour = 2 * face + ((i / 3) % 2);
        model.cloud.push_back(p, palette[(colour + static_cast<int>(rng() % 8 == 0)) % 6]);
      }
    }
  }
  model.features = mfot::compute_smr(model.cloud.colors);
  return model;
}

// The model seen at `truth` with 1.5 mm noise, plus clutter points around it, `points` in all.
HypothesisData make_hypothesis(const ObjectModel& model, const Pose& truth, std::size_t points, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  HypothesisData data;
  const Eigen::Isometry3f to_camera = truth.isometry();
  for (std::size_t j = 0; j < points; ++j) {
    if (j < model.cloud.size() && uniform01(rng) < 0.97f) {
      data.points.push_back(to_camera * model.cloud.positions[j] +
                            0.0015f * Eigen::Vector3f(gaussian(rng), gaussian(rng), gaussian(rng)));
      data.colors.push_back(model.cloud.colors[j]);
    } else {
      data.points.push_back(truth.translation + 0.15f * Eigen::Vector3f(uniform01(rng) - 0.5f, uniform01(rng) - 0.5f,
                                                                        uniform01(rng) - 0.5f));
      data.colors.push_back({static_cast<std::uint8_t>(rng() & 0xff), static_cast<std::uint8_t>((rng() >> 8) & 0xff),
                             static_cast<std::uint8_t>((rng() >> 16) & 0xff)});
    }
  }
  data.features = mfot::compute_smr(data.colors);
  return data;
}

// A particle set around truth, as the filter's diffusion leaves it.
std::vector<Pose> make_particles(const Pose& truth, std::size_t n, float sigma_t, float sigma_r, std::mt19937_64& rng) {
  std::vector<Pose> particles(n, truth);
  for (Pose& p : particles) {
    p.translation += sigma_t * Eigen::Vector3f(gaussian(rng), gaussian(rng), gaussian(rng));
    const Eigen::Vector3f w = sigma_r * Eigen::Vector3f(gaussian(rng), gaussian(rng), gaussian(rng));
    if (w.norm() > 0.f)
      p.rotation = (Eigen::Quaternionf(Eigen::AngleAxisf(w.norm(), w.normalized())) * p.rotation).normalized();
  }
  return particles;
}

using mfot::bench::median;
using mfot::bench::ms_since;

struct Scene {
  ObjectModel model;
  HypothesisData data;
  std::array<std::vector<Pose>, 4> particle_sets;
};

Scene make_scene(const Eigen::Vector3f& size, std::size_t points, std::size_t particles, float sigma_t, float sigma_r,
                 std::uint64_t seed) {
  Scene scene;
  scene.model = make_box_model(size, 0.005f, seed);
  Pose truth;
  truth.translation = Eigen::Vector3f(0.05f, -0.02f, 0.85f);
  truth.rotation = Eigen::Quaternionf(Eigen::AngleAxisf(0.6f, Eigen::Vector3f(0.2f, 1.f, 0.3f).normalized()));
  scene.data = make_hypothesis(scene.model, truth, points, seed + 1);
  std::mt19937_64 rng(seed + 2);
  for (auto& set : scene.particle_sets) set = make_particles(truth, particles, sigma_t, sigma_r, rng);
  return scene;
}

// Median wall time of one CPU evaluate, rotating over the particle sets.
double cpu_ms(mfot::JcsdLikelihood& cpu, const Scene& scene, int reps, std::vector<float>& scores) {
  std::vector<double> times;
  cpu.evaluate(scene.particle_sets[0], scene.data, scores);
  for (int r = 0; r < reps; ++r) {
    const auto start = Clock::now();
    cpu.evaluate(scene.particle_sets[static_cast<std::size_t>(r) % 4], scene.data, scores);
    times.push_back(ms_since(start));
  }
  return median(times);
}

struct GpuFigures {
  double kernel_ms = 0.0, events_ms = 0.0, wall_ms = 0.0;
};

#if MFOT_HAVE_CUDA
GpuFigures gpu_ms(mfot::CudaJcsdLikelihood& gpu, const Scene& scene, int reps, std::vector<float>& scores) {
  for (int w = 0; w < 5; ++w) gpu.evaluate(scene.particle_sets[static_cast<std::size_t>(w) % 4], scene.data, scores);
  std::vector<double> kernel, events, wall;
  for (int r = 0; r < reps; ++r) {
    const auto start = Clock::now();
    gpu.evaluate(scene.particle_sets[static_cast<std::size_t>(r) % 4], scene.data, scores);
    wall.push_back(ms_since(start));
    kernel.push_back(gpu.last_timing().kernel_ms);
    events.push_back(gpu.last_timing().transfer_ms);
  }
  return {median(kernel), median(events), median(wall)};
}

double max_relative_difference(const std::vector<float>& reference, const std::vector<float>& other) {
  double worst = 0.0;
  for (std::size_t i = 0; i < reference.size(); ++i) {
    const double d = std::abs(static_cast<double>(other[i]) - reference[i]);
    worst = std::max(worst, d / std::max(std::abs(static_cast<double>(reference[i])), 1e-9));
  }
  return worst;
}
#endif

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  }
  return "unknown CPU";
}

// NaN marks a figure that was not measured (printed as n/a).
struct Row {
  std::string label;
  std::size_t particles = 0, points = 0;
  double cpu = NAN;
  GpuFigures gpu{NAN, NAN, NAN};
  double parity = NAN;
  double thesis_cpu = NAN, thesis_gpu = NAN;
};

std::string fmt(double v, int decimals = 3, char style = 'f') {
  if (std::isnan(v)) return "n/a";
  char buf[32];
  std::snprintf(buf, sizeof buf, style == 'e' ? "%.*e" : "%.*f", decimals, v);
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  std::string csv_path;
  bool quick = false;
  long only = 0;  // 0: every row
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--csv") == 0 && i + 1 < argc) {
      csv_path = argv[++i];
    } else if (std::strcmp(argv[i], "--quick") == 0) {
      quick = true;
    } else if (std::strcmp(argv[i], "--only") == 0 && i + 1 < argc && (only = std::atol(argv[i + 1])) > 0) {
      ++i;
    } else {
      std::fprintf(stderr, "usage: %s [--csv FILE] [--quick] [--only PARTICLES]\n", argv[0]);
      return 2;
    }
  }

  std::string why;
  const bool have_gpu = mfot::cuda_available(&why);
  const std::time_t now = std::time(nullptr);
  char date[32];
  std::strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
  std::printf("JCSD hypothesis evaluation, thesis Table 4.1 (%s)\n", date);
  std::printf("CPU: %s, 1 thread\n", cpu_model().c_str());
  std::string device = "n/a (" + why + ")";
#if MFOT_HAVE_CUDA
  std::unique_ptr<mfot::CudaJcsdLikelihood> gpu;
  if (have_gpu) {
    try {
      gpu = std::make_unique<mfot::CudaJcsdLikelihood>();
      device = gpu->device_description();
    } catch (const std::exception& e) {
      device = std::string("n/a (") + e.what() + ")";
    }
  }
#endif
  std::printf("GPU: %s\n", device.c_str());

  const int cpu_reps = quick ? 3 : 15;
  [[maybe_unused]] const int gpu_reps = quick ? 20 : 200;  // used only with CUDA
  const std::array<std::size_t, 9> counts{10, 20, 50, 100, 200, 500, 1000, 2000, 5000};
  const std::array<double, 9> thesis_cpu{9.7, 16.9, 35, 67, 130, 343, 654, 1445, NAN};
  const std::array<double, 9> thesis_gpu{0.82, 0.93, 1.13, 1.8, 2.35, 3.8, 6.1, 11, NAN};
  const Eigen::Vector3f box(0.12f, 0.08f, 0.06f);  // 3 faces at 5 mm: 864 points
  constexpr std::size_t kPoints = 900;
  // Particle spread: sigma 5 mm / 0.03 rad, a filter's diffusion around a tracked object.
  constexpr float kSigmaT = 0.005f, kSigmaR = 0.03f;

  std::vector<Row> rows;
  mfot::JcsdLikelihood cpu;
  for (std::size_t k = 0; k < counts.size(); ++k) {
    if (only != 0 && counts[k] != static_cast<std::size_t>(only)) continue;
    const Scene scene = make_scene(box, kPoints, counts[k], kSigmaT, kSigmaR, 100 + k);
    Row row{"object", counts[k], scene.data.points.size(), NAN, {NAN, NAN, NAN}, NAN, thesis_cpu[k], thesis_gpu[k]};
    std::vector<float> cpu_scores(counts[k]);
    cpu.set_model(scene.model);
    if (!(quick && counts[k] > 2000)) row.cpu = cpu_ms(cpu, scene, cpu_reps, cpu_scores);
#if MFOT_HAVE_CUDA
    if (gpu) {
      std::vector<float> gpu_scores(counts[k]);
      gpu->set_grid(cpu.grid());
      row.gpu = gpu_ms(*gpu, scene, gpu_reps, gpu_scores);
      cpu.evaluate(scene.particle_sets[0], scene.data, cpu_scores);
      gpu->evaluate(scene.particle_sets[0], scene.data, gpu_scores);
      row.parity = max_relative_difference(cpu_scores, gpu_scores);
    }
#endif
    rows.push_back(row);
  }

  // The same 2000-particle frame with a wide spread (3 cm / 0.3 rad): less cache sharing
  // between the particles of a warp.
  if (only == 0) {
    const Scene scene = make_scene(box, kPoints, 2000, 0.03f, 0.3f, 300);
    Row row{"object-wide", 2000, scene.data.points.size(), NAN, {NAN, NAN, NAN}, NAN, NAN, NAN};
    std::vector<float> cpu_scores(2000);
    cpu.set_model(scene.model);
    row.cpu = cpu_ms(cpu, scene, cpu_reps, cpu_scores);
#if MFOT_HAVE_CUDA
    if (gpu) {
      std::vector<float> gpu_scores(2000);
      gpu->set_grid(cpu.grid());
      row.gpu = gpu_ms(*gpu, scene, gpu_reps, gpu_scores);
      cpu.evaluate(scene.particle_sets[0], scene.data, cpu_scores);
      gpu->evaluate(scene.particle_sets[0], scene.data, gpu_scores);
      row.parity = max_relative_difference(cpu_scores, gpu_scores);
    }
#endif
    rows.push_back(row);
  }

  // A frame of 3 objects, 1000 particles and 2000 hypothesis points each, evaluated one object
  // after the other (one likelihood instance per object, as the tracker holds them).
  if (only == 0) {
    const std::array<Eigen::Vector3f, 3> sizes{Eigen::Vector3f(0.20f, 0.12f, 0.08f),
                                               Eigen::Vector3f(0.16f, 0.16f, 0.10f),
                                               Eigen::Vector3f(0.25f, 0.10f, 0.07f)};
    std::array<Scene, 3> scenes;
    std::array<std::unique_ptr<mfot::JcsdLikelihood>, 3> cpus;
    for (std::size_t o = 0; o < 3; ++o) {
      scenes[o] = make_scene(sizes[o], 2000, 1000, kSigmaT, kSigmaR, 400 + 10 * o);
      cpus[o] = std::make_unique<mfot::JcsdLikelihood>();
      cpus[o]->set_model(scenes[o].model);
    }
    Row row{"3-objects", 3000, 6000, NAN, {NAN, NAN, NAN}, NAN, NAN, NAN};
    std::vector<float> scores(1000);
    std::vector<double> cpu_times;
    for (int r = 0; r < cpu_reps; ++r) {
      const auto start = Clock::now();
      for (std::size_t o = 0; o < 3; ++o)
        cpus[o]->evaluate(scenes[o].particle_sets[static_cast<std::size_t>(r) % 4], scenes[o].data, scores);
      cpu_times.push_back(ms_since(start));
    }
    row.cpu = median(cpu_times);
#if MFOT_HAVE_CUDA
    if (gpu) {
      std::array<std::unique_ptr<mfot::CudaJcsdLikelihood>, 3> gpus;
      for (std::size_t o = 0; o < 3; ++o) {
        gpus[o] = std::make_unique<mfot::CudaJcsdLikelihood>();
        gpus[o]->set_grid(cpus[o]->grid());
        gpus[o]->evaluate(scenes[o].particle_sets[0], scenes[o].data, scores);
      }
      std::vector<double> kernel, events, wall;
      for (int r = 0; r < gpu_reps; ++r) {
        double k = 0.0, e = 0.0;
        const auto start = Clock::now();
        for (std::size_t o = 0; o < 3; ++o) {
          gpus[o]->evaluate(scenes[o].particle_sets[static_cast<std::size_t>(r) % 4], scenes[o].data, scores);
          k += gpus[o]->last_timing().kernel_ms;
          e += gpus[o]->last_timing().transfer_ms;
        }
        wall.push_back(ms_since(start));
        kernel.push_back(k);
        events.push_back(e);
      }
      row.gpu = GpuFigures{median(kernel), median(events), median(wall)};
      double worst = 0.0;
      std::vector<float> cpu_scores(1000);
      for (std::size_t o = 0; o < 3; ++o) {
        cpus[o]->evaluate(scenes[o].particle_sets[0], scenes[o].data, cpu_scores);
        gpus[o]->evaluate(scenes[o].particle_sets[0], scenes[o].data, scores);
        worst = std::max(worst, max_relative_difference(cpu_scores, scores));
      }
      row.parity = worst;
    }
#endif
    rows.push_back(row);
  }

#if MFOT_HAVE_CUDA
  // Launch shape: the 2000-particle frame at several point splits (CudaJcsdLikelihoodOptions::
  // point_splits; 0, the default, chooses per call).
  if (gpu && only == 0) {
    const Scene scene = make_scene(box, kPoints, 2000, kSigmaT, kSigmaR, 107);
    cpu.set_model(scene.model);
    std::printf("\npoint_splits sweep, 2000 particles x %zu points: kernel ms", scene.data.points.size());
    for (const int splits : {0, 1, 2, 3, 4}) {
      mfot::CudaJcsdLikelihoodOptions options;
      options.point_splits = splits;
      mfot::CudaJcsdLikelihood tuned(options);
      tuned.set_grid(cpu.grid());
      std::vector<float> scores(2000);
      const double kernel_ms = gpu_ms(tuned, scene, gpu_reps, scores).kernel_ms;
      std::printf("  %d%s: %.4f", tuned.last_timing().point_splits, splits == 0 ? " (auto)" : "", kernel_ms);
    }
    std::printf("\n");
  }
#endif

  std::printf("\n%-12s %9s %6s %10s %11s %11s %11s %9s %9s %9s %9s %9s\n", "case", "particles", "points", "cpu_ms",
              "gpu_kern_ms", "gpu_dev_ms", "gpu_wall_ms", "speedup", "spd_kern", "parity", "thesis_cpu", "thesis_gpu");
  std::ofstream csv;
  if (!csv_path.empty()) {
    csv.open(csv_path);
    csv << "case,particles,points,cpu_ms,gpu_kernel_ms,gpu_device_ms,gpu_wall_ms,speedup_wall,speedup_kernel,"
           "max_rel_diff,thesis_cpu_ms,thesis_gpu_ms,gpu,date\n";
  }
  for (const Row& r : rows) {
    const double speedup = r.cpu / r.gpu.wall_ms;  // NaN when either is missing
    const double speedup_kernel = r.cpu / r.gpu.kernel_ms;
    std::printf("%-12s %9zu %6zu %10s %11s %11s %11s %9s %9s %9s %9s %9s\n", r.label.c_str(), r.particles, r.points,
                fmt(r.cpu).c_str(), fmt(r.gpu.kernel_ms, 4).c_str(), fmt(r.gpu.events_ms, 4).c_str(),
                fmt(r.gpu.wall_ms, 4).c_str(), fmt(speedup, 1).c_str(), fmt(speedup_kernel, 1).c_str(),
                fmt(r.parity, 1, 'e').c_str(), fmt(r.thesis_cpu, 1).c_str(), fmt(r.thesis_gpu, 2).c_str());
    if (csv.is_open()) {
      csv << r.label << ',' << r.particles << ',' << r.points << ',' << fmt(r.cpu, 4) << ',' << fmt(r.gpu.kernel_ms, 5)
          << ',' << fmt(r.gpu.events_ms, 5) << ',' << fmt(r.gpu.wall_ms, 5) << ',' << fmt(speedup, 2) << ','
          << fmt(speedup_kernel, 2) << ',' << fmt(r.parity, 2, 'e') << ',' << fmt(r.thesis_cpu, 2) << ','
          << fmt(r.thesis_gpu, 2) << ",\"" << device << "\"," << date << '\n';
    }
  }
  std::printf(
      "\ncpu_ms: JcsdLikelihood, 1 thread. gpu_kern_ms: scoring kernel (CUDA events). gpu_dev_ms: uploads +\n"
      "kernel + download (CUDA events). gpu_wall_ms: one evaluate() call. speedup = cpu_ms / gpu_wall_ms,\n"
      "spd_kern = cpu_ms / gpu_kern_ms. parity: largest relative CPU/GPU score difference. Medians.\n"
      "Particles: sigma 5 mm / 0.03 rad around the true pose (object-wide: 3 cm / 0.3 rad).\n");
  if (!have_gpu) std::printf("GPU n/a: %s\n", why.c_str());
  return 0;
}
