#include "mfot/discovery_confirmation.hpp"

#include <algorithm>
#include <tuple>

namespace mfot {

DiscoveryConfirmation::DiscoveryConfirmation(const DiscoveryOptions& options)
    : options_((options.validate(), options)) {}

PartMatch DiscoveryConfirmation::match(const std::vector<std::vector<int>>& parts,
                                       std::span<const std::int32_t> labels) {
  PartMatch match;
  match.labels_in_part.resize(parts.size());
  match.member_of_part.assign(parts.size(), 0);
  std::vector<std::tuple<std::size_t, std::int32_t, std::size_t>> overlaps;  // (points, member, part)
  for (std::size_t p = 0; p < parts.size(); ++p) {
    for (const int i : parts[p]) ++match.labels_in_part[p][labels[static_cast<std::size_t>(i)]];
    for (const auto& [id, count] : match.labels_in_part[p]) overlaps.emplace_back(count, id, p);
  }
  std::sort(overlaps.begin(), overlaps.end(), [](const auto& x, const auto& y) {
    return std::get<0>(x) != std::get<0>(y) ? std::get<0>(x) > std::get<0>(y) : std::get<1>(x) < std::get<1>(y);
  });
  for (const auto& [count, id, p] : overlaps) {
    if (match.member_of_part[p] == 0 && !match.part_of_member.contains(id)) {
      match.member_of_part[p] = id;
      match.part_of_member[id] = p;
    }
  }
  return match;
}

bool PartMatch::disagrees(std::size_t min_piece) const {
  if (std::count(member_of_part.begin(), member_of_part.end(), 0) > 0) return true;
  for (std::size_t p = 0; p < member_of_part.size(); ++p) {
    for (const auto& [id, count] : labels_in_part[p]) {
      if (id != member_of_part[p] && part_of_member.contains(id) && count >= min_piece) return true;
    }
  }
  return false;
}

void DiscoveryConfirmation::watch_siblings(const std::map<std::int32_t, std::vector<int>>& members,
                                           const PartMatch& match) {
  std::map<std::int32_t, std::pair<std::size_t, std::size_t>> main_part;  // member -> (its points there, part)
  for (std::size_t p = 0; p < match.labels_in_part.size(); ++p) {
    for (const auto& [id, count] : match.labels_in_part[p]) {
      if (!members.contains(id)) continue;
      auto& best = main_part[id];
      if (count > best.first) best = {count, p};
    }
  }
  for (auto a = main_part.begin(); a != main_part.end(); ++a) {
    for (auto b = std::next(a); b != main_part.end(); ++b) {
      SiblingWatch& watch = siblings_[{a->first, b->first}];
      ++(a->second.second == b->second.second ? watch.together : watch.apart);
    }
  }
}

bool DiscoveryConfirmation::vote(std::uint64_t birth, bool disagrees) {
  if (!disagrees || ++votes_[birth] < options_.confirm_votes) return false;
  votes_[birth] = 0;
  return true;
}

void DiscoveryConfirmation::keep_votes_of(const std::function<bool(std::uint64_t)>& births) {
  std::erase_if(votes_, [&](const auto& entry) { return !births(entry.first); });
}

std::vector<std::pair<std::int32_t, std::int32_t>> DiscoveryConfirmation::unparted_siblings(
    std::span<const std::int32_t> leaving, const std::function<std::size_t(std::int32_t)>& model_size) {
  const int min_together = options_.confirm_frames - options_.confirm_votes + 1;
  std::vector<std::pair<std::int32_t, std::int32_t>> decided;  // (larger, smaller)
  for (auto it = siblings_.begin(); it != siblings_.end();) {
    const auto [a, b] = it->first;
    if (std::find(leaving.begin(), leaving.end(), a) == leaving.end() &&
        std::find(leaving.begin(), leaving.end(), b) == leaving.end()) {
      ++it;
      continue;
    }
    if (it->second.apart == 0 && it->second.together >= min_together) {
      const bool a_larger = model_size(a) >= model_size(b);
      decided.emplace_back(a_larger ? a : b, a_larger ? b : a);
    }
    it = siblings_.erase(it);
  }
  std::map<std::int32_t, std::int32_t> joined_into;
  const auto now_in = [&](std::int32_t id) {
    for (auto it = joined_into.find(id); it != joined_into.end(); it = joined_into.find(id)) id = it->second;
    return id;
  };
  std::vector<std::pair<std::int32_t, std::int32_t>> joins;
  for (const auto& [larger, smaller] : decided) {
    const std::int32_t kept = now_in(larger), joined = now_in(smaller);
    if (kept == joined) continue;
    joins.emplace_back(kept, joined);
    joined_into[joined] = kept;
  }
  return joins;
}

void DiscoveryConfirmation::forget(std::int32_t id) {
  std::erase_if(siblings_, [id](const auto& entry) { return entry.first.first == id || entry.first.second == id; });
}

}  // namespace mfot
