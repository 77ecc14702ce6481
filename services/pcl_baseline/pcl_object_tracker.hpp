#pragma once
// One object tracked by PCL's own tracker, pcl::tracking::KLDAdaptiveParticleFilterOMPTracker,
// behind a plain interface (std types only). Its .cpp is compiled for the baseline ISA like the
// PCL libraries themselves: with -march=native Eigen's alignment inside PCL's headers would differ
// from the library's, so no Eigen type crosses this interface. It is a shared library with hidden
// symbols apart from these classes, so its Eigen code never mixes with the -march=native copies.

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#define MFOT_PCL_EXPORT __attribute__((visibility("default")))

namespace mfot::pcl_baseline {

// The settings of PCL's tracking example (apps/src/openni_tracking.cpp) unless a comment says
// otherwise; configs/pcl_baseline.yaml documents each key.
struct MFOT_PCL_EXPORT PclTrackerSettings {
  int particles = 400;       // setParticleNum, initial particle count
  int max_particles = 500;   // setMaximumParticleNum, the KLD bound's ceiling
  double kld_delta = 0.99;   // setDelta
  double kld_epsilon = 0.2;  // setEpsilon
  double bin_size = 0.1;     // setBinSize, every state dimension (m, rad)
  // Standard deviations (x, y, z in m; roll, pitch, yaw in rad); PCL takes variances.
  std::array<double, 6> step_noise_sigma{0.015, 0.015, 0.015, 0.0949, 0.0949, 0.0949};
  std::array<double, 6> initial_noise_sigma{0.00316, 0.00316, 0.00316, 0.00316, 0.00316, 0.00316};
  int iterations = 1;               // setIterationNum
  double color_weight = 0.1;        // HSVColorCoherence::setWeight (DistanceCoherence keeps weight 1)
  double max_distance = 0.01;       // ApproxNearestPairPointCloudCoherence::setMaximumDistance, m
  double octree_resolution = 0.01;  // pcl::search::Octree resolution, m
  float reference_leaf = 0.01f;     // reference cloud voxel grid (the example's downsampling_grid_size), m
  int threads = 1;                  // OpenMP threads of the OMP tracker

  // Throws std::invalid_argument naming the field and its allowed range.
  void validate() const;
};

struct PlainPose {
  std::array<float, 3> translation{0.f, 0.f, 0.f};    // object -> camera, m
  std::array<float, 4> rotation{0.f, 0.f, 0.f, 1.f};  // unit quaternion x, y, z, w
};

// The preprocessed scene of one frame as a PCL cloud, shared by every object's tracker.
class MFOT_PCL_EXPORT PclScene {
 public:
  PclScene();
  ~PclScene();
  PclScene(const PclScene&) = delete;
  PclScene& operator=(const PclScene&) = delete;

  // xyz: 3 floats per point (camera frame, m); rgb: 3 bytes per point. Throws std::invalid_argument
  // when the sizes disagree.
  void assign(const std::vector<float>& xyz, const std::vector<std::uint8_t>& rgb);
  std::size_t size() const;

 private:
  friend class PclObjectTracker;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

class MFOT_PCL_EXPORT PclObjectTracker {
 public:
  // reference_xyz / reference_rgb: the object's model in its own frame (3 values per point);
  // initial: the model's pose in the first frame. Throws std::invalid_argument for an empty or
  // inconsistent reference or invalid settings.
  PclObjectTracker(const PclTrackerSettings& settings, const std::vector<float>& reference_xyz,
                   const std::vector<std::uint8_t>& reference_rgb, const PlainPose& initial);
  ~PclObjectTracker();
  PclObjectTracker(const PclObjectTracker&) = delete;
  PclObjectTracker& operator=(const PclObjectTracker&) = delete;

  // One filter step on the frame's scene; returns the estimate (the weighted mean state).
  PlainPose track(const PclScene& scene);
  // Particles used in the last step (the KLD bound adapts it).
  int particles_used() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mfot::pcl_baseline
