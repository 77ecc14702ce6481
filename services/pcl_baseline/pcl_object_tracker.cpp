#include "pcl_object_tracker.hpp"

#include <pcl/filters/approximate_voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/octree.h>
#include <pcl/tracking/approx_nearest_pair_point_cloud_coherence.h>
#include <pcl/tracking/distance_coherence.h>
#include <pcl/tracking/hsv_color_coherence.h>
#include <pcl/tracking/kld_adaptive_particle_filter_omp.h>
#include <pcl/tracking/tracking.h>

#include <cmath>
#include <stdexcept>
#include <string>

namespace mfot::pcl_baseline {

namespace {
using Point = pcl::PointXYZRGBA;
using Cloud = pcl::PointCloud<Point>;
using Particle = pcl::tracking::ParticleXYZRPY;
using Tracker = pcl::tracking::KLDAdaptiveParticleFilterOMPTracker<Point, Particle>;

void require(bool ok, const std::string& field, const std::string& range) {
  if (!ok) throw std::invalid_argument("pcl_baseline." + field + " must be " + range);
}

Cloud::Ptr to_cloud(const std::vector<float>& xyz, const std::vector<std::uint8_t>& rgb, const char* what) {
  if (xyz.size() % 3 != 0 || rgb.size() != xyz.size()) {
    throw std::invalid_argument(std::string(what) + ": expected 3 coordinates and 3 colour bytes per point, got " +
                                std::to_string(xyz.size()) + " coordinates and " + std::to_string(rgb.size()) +
                                " bytes");
  }
  Cloud::Ptr cloud(new Cloud);
  const std::size_t n = xyz.size() / 3;
  cloud->resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    Point& p = (*cloud)[i];
    p.x = xyz[3 * i];
    p.y = xyz[3 * i + 1];
    p.z = xyz[3 * i + 2];
    p.r = rgb[3 * i];
    p.g = rgb[3 * i + 1];
    p.b = rgb[3 * i + 2];
    p.a = 255;
  }
  return cloud;
}
}  // namespace

void PclTrackerSettings::validate() const {
  require(particles >= 1 && particles <= 100000, "particles", "in [1, 100000]");
  require(max_particles >= particles && max_particles <= 100000, "max_particles", "in [particles, 100000]");
  require(kld_delta > 0.0 && kld_delta < 1.0, "kld_delta", "in (0, 1)");
  require(kld_epsilon > 0.0 && kld_epsilon <= 10.0, "kld_epsilon", "in (0, 10]");
  require(bin_size > 0.0 && bin_size <= 10.0, "bin_size", "in (0, 10]");
  for (const double s : step_noise_sigma)
    require(std::isfinite(s) && s >= 0.0 && s <= 1.0, "step_noise_sigma", "6 values in [0, 1]");
  for (const double s : initial_noise_sigma) {
    require(std::isfinite(s) && s >= 0.0 && s <= 1.0, "initial_noise_sigma", "6 values in [0, 1]");
  }
  require(iterations >= 1 && iterations <= 100, "iterations", "in [1, 100]");
  require(color_weight >= 0.0 && color_weight <= 100.0, "color_weight", "in [0, 100]");
  require(max_distance > 0.0 && max_distance <= 1.0, "max_distance", "in (0, 1]");
  require(octree_resolution > 0.0 && octree_resolution <= 1.0, "octree_resolution", "in (0, 1]");
  require(reference_leaf >= 0.f && reference_leaf <= 0.1f, "reference_leaf", "in [0, 0.1] (0: no downsampling)");
  require(threads >= 1 && threads <= 256, "threads", "in [1, 256]");
}

struct PclScene::Impl {
  Cloud::Ptr cloud{new Cloud};
};

PclScene::PclScene() : impl_(std::make_unique<Impl>()) {}
PclScene::~PclScene() = default;

void PclScene::assign(const std::vector<float>& xyz, const std::vector<std::uint8_t>& rgb) {
  // A fresh cloud each frame: the trackers' coherences rebuild their search structure when the
  // input pointer changes.
  impl_->cloud = to_cloud(xyz, rgb, "PclScene::assign");
}

std::size_t PclScene::size() const { return impl_->cloud->size(); }

struct PclObjectTracker::Impl {
  Tracker::Ptr tracker;
};

PclObjectTracker::PclObjectTracker(const PclTrackerSettings& settings, const std::vector<float>& reference_xyz,
                                   const std::vector<std::uint8_t>& reference_rgb, const PlainPose& initial)
    : impl_(std::make_unique<Impl>()) {
  settings.validate();
  Cloud::Ptr reference = to_cloud(reference_xyz, reference_rgb, "PclObjectTracker reference");
  if (reference->empty()) throw std::invalid_argument("PclObjectTracker: the reference cloud is empty");
  if (settings.reference_leaf > 0.f) {
    pcl::ApproximateVoxelGrid<Point> grid;
    grid.setLeafSize(settings.reference_leaf, settings.reference_leaf, settings.reference_leaf);
    grid.setInputCloud(reference);
    Cloud::Ptr downsampled(new Cloud);
    grid.filter(*downsampled);
    if (!downsampled->empty()) reference = downsampled;
  }

  auto tracker = Tracker::Ptr(new Tracker(static_cast<unsigned>(settings.threads)));
  tracker->setMaximumParticleNum(settings.max_particles);
  tracker->setDelta(settings.kld_delta);
  tracker->setEpsilon(settings.kld_epsilon);
  Particle bin;
  bin.x = bin.y = bin.z = bin.roll = bin.pitch = bin.yaw = static_cast<float>(settings.bin_size);
  tracker->setBinSize(bin);
  std::vector<double> step_variance(6), initial_variance(6);
  for (std::size_t i = 0; i < 6; ++i) {
    step_variance[i] = settings.step_noise_sigma[i] * settings.step_noise_sigma[i];
    initial_variance[i] = settings.initial_noise_sigma[i] * settings.initial_noise_sigma[i];
  }
  tracker->setStepNoiseCovariance(step_variance);
  tracker->setInitialNoiseCovariance(initial_variance);
  tracker->setInitialNoiseMean(std::vector<double>(6, 0.0));
  tracker->setIterationNum(settings.iterations);
  tracker->setParticleNum(settings.particles);
  tracker->setResampleLikelihoodThr(0.0);
  tracker->setUseNormal(false);

  using Coherence = pcl::tracking::ApproxNearestPairPointCloudCoherence<Point>;
  auto coherence = Coherence::Ptr(new Coherence);
  coherence->addPointCoherence(
      pcl::tracking::DistanceCoherence<Point>::Ptr(new pcl::tracking::DistanceCoherence<Point>));
  auto colour = pcl::tracking::HSVColorCoherence<Point>::Ptr(new pcl::tracking::HSVColorCoherence<Point>);
  colour->setWeight(settings.color_weight);
  coherence->addPointCoherence(colour);
  coherence->setSearchMethod(
      pcl::search::Octree<Point>::Ptr(new pcl::search::Octree<Point>(settings.octree_resolution)));
  coherence->setMaximumDistance(settings.max_distance);
  tracker->setCloudCoherence(coherence);

  Eigen::Affine3f trans = Eigen::Affine3f::Identity();
  trans.linear() =
      Eigen::Quaternionf(initial.rotation[3], initial.rotation[0], initial.rotation[1], initial.rotation[2])
          .normalized()
          .toRotationMatrix();
  trans.translation() = Eigen::Vector3f(initial.translation[0], initial.translation[1], initial.translation[2]);
  tracker->setTrans(trans);
  tracker->setReferenceCloud(reference);
  impl_->tracker = tracker;
}

PclObjectTracker::~PclObjectTracker() = default;

PlainPose PclObjectTracker::track(const PclScene& scene) {
  impl_->tracker->setInputCloud(scene.impl_->cloud);
  impl_->tracker->compute();
  const Particle result = impl_->tracker->getResult();
  const Eigen::Affine3f transform = impl_->tracker->toEigenMatrix(result);
  const Eigen::Quaternionf q(transform.rotation());
  PlainPose pose;
  pose.translation = {transform.translation().x(), transform.translation().y(), transform.translation().z()};
  pose.rotation = {q.x(), q.y(), q.z(), q.w()};
  return pose;
}

int PclObjectTracker::particles_used() const {
  const auto particles = impl_->tracker->getParticles();
  return particles ? static_cast<int>(particles->size()) : 0;
}

}  // namespace mfot::pcl_baseline
