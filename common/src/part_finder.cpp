#include "mfot/part_finder.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace mfot {

PartFinder::PartFinder(std::vector<std::unique_ptr<ObjectDiscovery>> discoveries, const PartBoundaryOptions& boundary,
                       std::size_t min_points, ThreadPool& pool)
    : pool_(pool), min_points_(min_points) {
  if (min_points == 0) throw std::invalid_argument("PartFinder: min_points must be >= 1");
  for (auto& discovery : discoveries) {
    if (!discovery) throw std::invalid_argument("PartFinder: a discovery is null");
    workers_.push_back(std::make_unique<Worker>(std::move(discovery), boundary));
  }
}

void PartFinder::find(const ColoredCloud& scene, std::span<const std::vector<int>> sets,
                      std::vector<std::vector<std::vector<int>>>& parts) {
  if (!enabled()) throw std::logic_error("PartFinder::find: no discovery");
  for (const std::vector<int>& set : sets) {
    for (const int i : set) {
      if (i < 0 || static_cast<std::size_t>(i) >= scene.size()) {
        throw std::out_of_range("PartFinder::find: point index " + std::to_string(i) + " outside the scene of " +
                                std::to_string(scene.size()));
      }
    }
  }
  parts.resize(sets.size());
  // Worker w takes sets w, w + T, ...: each set's parts depend on its points only, whichever worker runs it.
  const std::size_t workers = std::min(workers_.size(), sets.size());
  pool_.run(workers, [&](std::size_t w) {
    for (std::size_t s = w; s < sets.size(); s += workers) find_one(*workers_[w], scene, sets[s], parts[s]);
  });
}

void PartFinder::find_one(Worker& worker, const ColoredCloud& scene, std::span<const int> set,
                          std::vector<std::vector<int>>& parts) const {
  parts.clear();
  if (set.size() < min_points_) return;
  worker.positions.clear();
  worker.colors.clear();
  for (const int i : set) {
    worker.positions.push_back(scene.positions[static_cast<std::size_t>(i)]);
    worker.colors.push_back(scene.colors[static_cast<std::size_t>(i)]);
  }
  const int count = worker.discovery->split(worker.positions, worker.colors, worker.part_of_point);
  worker.boundary.refine(worker.positions, worker.colors, worker.part_of_point);
  parts.assign(static_cast<std::size_t>(std::max(count, 1)), {});
  for (std::size_t k = 0; k < set.size(); ++k)
    parts[static_cast<std::size_t>(worker.part_of_point[k])].push_back(set[k]);
  std::erase_if(parts, [&](const std::vector<int>& part) { return part.size() < min_points_; });
}

}  // namespace mfot
