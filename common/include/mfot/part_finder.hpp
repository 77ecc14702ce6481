#pragma once
// The parts of point sets of one scene, several sets side by side (thesis 3.5's new objects, split as
// Stein et al. 2014, "Object Partitioning using Local Convexity", with the seams refined by
// PartBoundaryRefiner). Steps, for each set independently:
//   1. gather the set's positions and colours;
//   2. the discovery splits them into parts (ObjectDiscovery::split);
//   3. the seams between parts are refined;
//   4. parts smaller than min_points are dropped.
// One discovery per thread: a set's parts depend on its points alone, so they are the same for every
// thread count (the ObjectManager's births of a first frame and its confirmations run a frame's sets here
// together).

#include <Eigen/Core>
#include <memory>
#include <span>
#include <vector>

#include "mfot/object_discovery.hpp"
#include "mfot/part_boundary.hpp"
#include "mfot/thread_pool.hpp"
#include "mfot/types.hpp"

namespace mfot {

class PartFinder {
 public:
  // discoveries: one per thread of pool (which runs them; it must outlive the finder), none null; empty = no
  // discovery (enabled() is false, find() refuses). min_points: >= 1.
  PartFinder(std::vector<std::unique_ptr<ObjectDiscovery>> discoveries, const PartBoundaryOptions& boundary,
             std::size_t min_points, ThreadPool& pool);
  PartFinder(const PartFinder&) = delete;
  PartFinder& operator=(const PartFinder&) = delete;

  bool enabled() const { return !workers_.empty(); }
  int threads() const { return static_cast<int>(workers_.size()); }

  // parts[s]: the parts of sets[s] (indices into the scene, each in the set's order), each of at least
  // min_points; a set of fewer points than that has none. Throws std::logic_error when !enabled() and
  // std::out_of_range for an index outside the scene.
  void find(const ColoredCloud& scene, std::span<const std::vector<int>> sets,
            std::vector<std::vector<std::vector<int>>>& parts);

 private:
  struct Worker {
    Worker(std::unique_ptr<ObjectDiscovery> d, const PartBoundaryOptions& boundary_options)
        : discovery(std::move(d)), boundary(boundary_options) {}
    std::unique_ptr<ObjectDiscovery> discovery;
    PartBoundaryRefiner boundary;
    std::vector<Eigen::Vector3f> positions;
    std::vector<Rgb8> colors;
    std::vector<int> part_of_point;
  };
  void find_one(Worker& worker, const ColoredCloud& scene, std::span<const int> set,
                std::vector<std::vector<int>>& parts) const;

  std::vector<std::unique_ptr<Worker>> workers_;
  ThreadPool& pool_;
  std::size_t min_points_;
};

}  // namespace mfot
