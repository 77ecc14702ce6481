// Simulator rendering speed: 640x480 registered RGB-D frames (with labels and ground truth) per
// second on one core, per scenario, with the Kinect-like noise model on and off. Prints wall-clock
// and process CPU time (CPU time is the fairer figure on a loaded machine).
//
// Usage: mfot_bench_sim [frames_per_scenario (default 60)]

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>

#include "mfot/sim/simulator.hpp"

int main(int argc, char** argv) {
  const int frames = argc > 1 ? std::max(1, std::atoi(argv[1])) : 60;
  std::printf("%-8s %-6s %8s %12s %12s %10s\n", "scenario", "noise", "frames", "wall ms/fr", "cpu ms/fr", "fps (cpu)");
  for (const bool noise : {true, false}) {
    for (const std::string& name : mfot::sim::scenario_names()) {
      mfot::sim::SimulatorOptions options;
      options.scenario.name = name;
      options.sensor.noise = noise;
      const mfot::sim::Simulator simulator(options);
      const int step = std::max(1, simulator.num_frames() / frames);
      std::size_t checksum = 0;
      simulator.render(0);  // warm-up: first-touch page faults of the allocator
      const auto wall0 = std::chrono::steady_clock::now();
      const std::clock_t cpu0 = std::clock();
      int rendered = 0;
      for (int i = 0; i < simulator.num_frames() && rendered < frames; i += step, ++rendered) {
        checksum += simulator.render(i).depth_mm[320 * 240];
      }
      const double cpu_ms = 1000.0 * static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC / rendered;
      const double wall_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - wall0).count() / rendered;
      std::printf("%-8s %-6s %8d %12.2f %12.2f %10.1f   (checksum %zu)\n", name.c_str(), noise ? "on" : "off", rendered,
                  wall_ms, cpu_ms, 1000.0 / cpu_ms, checksum);
    }
  }
  return 0;
}
