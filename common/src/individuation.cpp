#include "mfot/individuation.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <tuple>

namespace mfot {

namespace {

template <class Options>
const Options& validated(const Options& options) {
  options.validate();
  return options;
}

bool is_finite(const Eigen::Vector3f& p) {
  return std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z());
}

}  // namespace

// ---- Euclidean clustering ----------------------------------------------------------------------

void EuclideanClusterOptions::validate() const {
  if (!(tolerance > 0.f && tolerance <= 1.f)) {
    throw std::invalid_argument("EuclideanClusterOptions.tolerance must be in (0, 1] metres, got " +
                                std::to_string(tolerance));
  }
  if (min_cluster_size < 1) throw std::invalid_argument("EuclideanClusterOptions.min_cluster_size must be >= 1");
}

EuclideanClusterer::EuclideanClusterer(const EuclideanClusterOptions& options)
    : options_(validated(options)), hash_(options.tolerance) {}

void EuclideanClusterer::cluster(std::span<const Eigen::Vector3f> points, ClusterSet& out) {
  out.point_indices.clear();
  out.offsets.assign(1, 0);
  out.cluster_of_point.assign(points.size(), -1);
  hash_.build(points);
  visited_.assign(points.size(), 0);

  for (std::size_t seed = 0; seed < points.size(); ++seed) {
    if (visited_[seed] || !is_finite(points[seed])) continue;
    visited_[seed] = 1;
    component_.assign(1, static_cast<int>(seed));
    frontier_.assign(1, static_cast<int>(seed));
    while (!frontier_.empty()) {
      const int p = frontier_.back();
      frontier_.pop_back();
      neighbours_.clear();
      hash_.radius_search(points[static_cast<std::size_t>(p)], options_.tolerance, neighbours_);
      for (const int n : neighbours_) {
        if (visited_[static_cast<std::size_t>(n)]) continue;
        visited_[static_cast<std::size_t>(n)] = 1;
        component_.push_back(n);
        frontier_.push_back(n);
      }
    }
    if (component_.size() < options_.min_cluster_size) continue;
    std::sort(component_.begin(), component_.end());
    const auto k = static_cast<std::int32_t>(out.size());
    for (const int i : component_) out.cluster_of_point[static_cast<std::size_t>(i)] = k;
    out.point_indices.insert(out.point_indices.end(), component_.begin(), component_.end());
    out.offsets.push_back(static_cast<int>(out.point_indices.size()));
  }
}

void unassigned_shares(const ClusterSet& clusters, std::span<const std::int32_t> labels, std::vector<float>& out) {
  out.resize(clusters.size());
  for (std::size_t k = 0; k < clusters.size(); ++k) {
    const auto members = clusters.cluster(k);
    std::size_t unassigned = 0;
    for (const int i : members) {
      if (static_cast<std::size_t>(i) >= labels.size())
        throw std::invalid_argument("unassigned_shares: labels shorter than the clustered points");
      if (labels[static_cast<std::size_t>(i)] == 0) ++unassigned;
    }
    out[k] = members.empty() ? 0.f : static_cast<float>(unassigned) / static_cast<float>(members.size());
  }
}

// ---- new objects -----------------------------------------------------------------------------

void NewObjectOptions::validate() const {
  if (!(min_unassigned_share > 0.f && min_unassigned_share <= 1.f)) {
    throw std::invalid_argument("NewObjectOptions.min_unassigned_share must be in (0, 1], got " +
                                std::to_string(min_unassigned_share));
  }
  if (confirm_frames < 1) {
    throw std::invalid_argument("NewObjectOptions.confirm_frames must be >= 1, got " + std::to_string(confirm_frames));
  }
  if (!(match_distance > 0.f && match_distance <= 1.f)) {
    throw std::invalid_argument("NewObjectOptions.match_distance must be in (0, 1] metres, got " +
                                std::to_string(match_distance));
  }
  if (!(min_overlap > 0.f && min_overlap <= 1.f)) {
    throw std::invalid_argument("NewObjectOptions.min_overlap must be in (0, 1], got " + std::to_string(min_overlap));
  }
}

NewObjectDetector::NewObjectDetector(const NewObjectOptions& options)
    : options_(validated(options)), hash_(options.match_distance) {}

void NewObjectDetector::reset() {
  candidates_.clear();
  next_key_ = 0;
}

void NewObjectDetector::update(std::span<const Eigen::Vector3f> points, const ClusterSet& clusters,
                               std::span<const std::int32_t> labels, std::vector<int>& confirmed,
                               std::size_t candidate_clusters) {
  if (labels.size() != points.size() || clusters.cluster_of_point.size() != points.size()) {
    throw std::invalid_argument("NewObjectDetector: points, labels and clusters must cover the same points");
  }
  confirmed.clear();
  unassigned_shares(clusters, labels, shares_);

  candidate_points_.clear();
  candidate_owner_.clear();
  for (std::size_t c = 0; c < candidates_.size(); ++c) {
    candidate_points_.insert(candidate_points_.end(), candidates_[c].points.begin(), candidates_[c].points.end());
    candidate_owner_.insert(candidate_owner_.end(), candidates_[c].points.size(), static_cast<int>(c));
  }
  hash_.build(candidate_points_);

  // (overlap, candidate, cluster) of every pair above min_overlap.
  std::vector<std::tuple<float, int, int>> pairs;
  std::vector<int> unexplained;
  for (std::size_t k = 0; k < std::min(clusters.size(), candidate_clusters); ++k) {
    if (!(shares_[k] > options_.min_unassigned_share)) continue;
    unexplained.push_back(static_cast<int>(k));
    if (candidates_.empty()) continue;
    const auto members = clusters.cluster(k);
    hits_.assign(candidates_.size(), 0);
    for (const int i : members) {
      neighbours_.clear();
      hash_.radius_search(points[static_cast<std::size_t>(i)], options_.match_distance, neighbours_);
      // A point counts once per candidate: neighbours_ is sorted by index and candidates' points
      // are contiguous, so one candidate's hits are adjacent.
      int last_owner = -1;
      for (const int n : neighbours_) {
        const int owner = candidate_owner_[static_cast<std::size_t>(n)];
        if (owner != last_owner) ++hits_[static_cast<std::size_t>(owner)];
        last_owner = owner;
      }
    }
    for (std::size_t c = 0; c < candidates_.size(); ++c) {
      const float overlap = static_cast<float>(hits_[c]) / static_cast<float>(members.size());
      if (overlap >= options_.min_overlap) pairs.emplace_back(overlap, static_cast<int>(c), static_cast<int>(k));
    }
  }
  std::sort(pairs.begin(), pairs.end(), [](const auto& a, const auto& b) {
    if (std::get<0>(a) != std::get<0>(b)) return std::get<0>(a) > std::get<0>(b);
    if (std::get<1>(a) != std::get<1>(b)) return std::get<1>(a) < std::get<1>(b);
    return std::get<2>(a) < std::get<2>(b);
  });
  std::vector<int> cluster_of_candidate(candidates_.size(), -1);
  std::vector<std::uint8_t> cluster_taken(clusters.size(), 0);
  for (const auto& [overlap, c, k] : pairs) {
    if (cluster_of_candidate[static_cast<std::size_t>(c)] >= 0 || cluster_taken[static_cast<std::size_t>(k)]) continue;
    cluster_of_candidate[static_cast<std::size_t>(c)] = k;
    cluster_taken[static_cast<std::size_t>(k)] = 1;
  }

  const auto take_points = [&](Candidate& candidate, int k) {
    candidate.cluster = k;
    candidate.points.clear();
    for (const int i : clusters.cluster(static_cast<std::size_t>(k)))
      candidate.points.push_back(points[static_cast<std::size_t>(i)]);
  };
  std::vector<Candidate> next;
  for (std::size_t c = 0; c < candidates_.size(); ++c) {
    if (cluster_of_candidate[c] < 0) continue;
    Candidate& candidate = next.emplace_back(std::move(candidates_[c]));
    ++candidate.frames;
    take_points(candidate, cluster_of_candidate[c]);
  }
  for (const int k : unexplained) {
    if (cluster_taken[static_cast<std::size_t>(k)]) continue;
    Candidate& candidate = next.emplace_back();
    candidate.key = next_key_++;
    candidate.frames = 1;
    take_points(candidate, k);
  }

  candidates_.clear();
  for (auto& candidate : next) {
    if (candidate.frames >= options_.confirm_frames) {
      confirmed.push_back(candidate.cluster);
    } else {
      candidates_.push_back(std::move(candidate));
    }
  }
  std::sort(confirmed.begin(), confirmed.end());
}

// ---- lost objects ----------------------------------------------------------------------------

void SupportLossOptions::validate() const {
  if (max_frames < 1)
    throw std::invalid_argument("SupportLossOptions.max_frames must be >= 1, got " + std::to_string(max_frames));
}

SupportMonitor::SupportMonitor(const SupportLossOptions& options) : options_(validated(options)) {}

int SupportMonitor::frames_without_support(std::int32_t id) const {
  for (const auto& [known, frames] : misses_) {
    if (known == id) return frames;
  }
  return 0;
}

void SupportMonitor::update(std::span<const std::int32_t> ids, std::span<const std::size_t> counts,
                            std::span<const std::uint8_t> hidden, std::vector<std::int32_t>& retired) {
  if (ids.size() != counts.size()) throw std::invalid_argument("SupportMonitor: ids and counts must have one size");
  if (!hidden.empty() && hidden.size() != ids.size()) {
    throw std::invalid_argument("SupportMonitor: hidden must be empty or have one flag per id");
  }
  retired.clear();
  next_misses_.clear();
  for (std::size_t k = 0; k < ids.size(); ++k) {
    const bool lacking = counts[k] < options_.min_points;
    const bool is_hidden = !hidden.empty() && hidden[k] != 0;
    const int frames = !lacking ? 0 : frames_without_support(ids[k]) + (is_hidden ? 0 : 1);
    if (frames >= options_.max_frames) {
      retired.push_back(ids[k]);
    } else {
      next_misses_.emplace_back(ids[k], frames);
    }
  }
  misses_.swap(next_misses_);
}

}  // namespace mfot
