#include "mfot/service/model_delta.hpp"

#include <algorithm>
#include <bit>
#include <limits>

namespace mfot::service {

namespace {
// Appends `count` to the runs, alternating kinds: `second` false is the first kind (even runs).
void add_run(std::vector<std::int32_t>& runs, bool second, std::size_t count) {
  if (count == 0) return;
  const bool last_second = runs.size() % 2 == 0;  // the kind the next run would have, negated
  if (!runs.empty() && last_second == second) {
    runs.back() += static_cast<std::int32_t>(count);
    return;
  }
  if (runs.empty() && second) runs.push_back(0);
  runs.push_back(static_cast<std::int32_t>(count));
}
}  // namespace

ModelDiffer::Key ModelDiffer::key_of(const Eigen::Vector3f& p, Rgb8 c) {
  return {
      std::bit_cast<std::uint32_t>(p.x()), std::bit_cast<std::uint32_t>(p.y()), std::bit_cast<std::uint32_t>(p.z()),
      static_cast<std::uint32_t>(c.r) | static_cast<std::uint32_t>(c.g) << 8 | static_cast<std::uint32_t>(c.b) << 16};
}

std::size_t ModelDiffer::KeyHash::operator()(const Key& k) const {
  std::uint64_t h = 0x9e3779b97f4a7c15ull;
  for (const std::uint32_t v : {k.x, k.y, k.z, k.rgb}) h = (h ^ v) * 0x100000001b3ull;
  return static_cast<std::size_t>(h ^ (h >> 29));
}

const ModelDelta& ModelDiffer::diff(const ColoredCloud& base, const ColoredCloud& model) {
  ModelDelta& out = delta_;
  out.base_runs.clear();
  out.order_runs.clear();
  out.new_points.clear();
  index_.clear();
  for (std::size_t j = 0; j < base.size(); ++j) {
    index_[key_of(base.positions[j], base.colors[j])].push_back(static_cast<std::uint32_t>(j));
  }
  std::size_t next_base = 0;  // base points before this one are taken or left out
  for (std::size_t i = 0; i < model.size(); ++i) {
    const auto it = index_.find(key_of(model.positions[i], model.colors[i]));
    if (it != index_.end()) {
      const auto at = std::lower_bound(it->second.begin(), it->second.end(), next_base);
      // A match past skipped base points is taken where the next point follows it too (a run of them
      // was left out), not for a point alone that moved back or repeats one further on.
      const auto continues = [&](std::uint32_t k) {
        return k == next_base || i + 1 == model.size() ||
               (k + 1 < base.size() && key_of(model.positions[i + 1], model.colors[i + 1]) ==
                                           key_of(base.positions[k + 1], base.colors[k + 1]));
      };
      if (at != it->second.end() && continues(*at)) {
        add_run(out.base_runs, true, *at - next_base);  // skipped: left out
        add_run(out.base_runs, false, 1);
        add_run(out.order_runs, false, 1);
        next_base = *at + 1;
        continue;
      }
    }
    add_run(out.order_runs, true, 1);
    out.new_points.push_back(static_cast<std::uint32_t>(i));
  }
  add_run(out.base_runs, true, base.size() - next_base);
  return out;
}

std::optional<std::string> apply_model_delta(const ColoredCloud& base, std::span<const std::int32_t> base_runs,
                                             std::span<const std::int32_t> order_runs, const ColoredCloud& new_points,
                                             ColoredCloud& out) {
  out.clear();
  std::int64_t base_total = 0, kept = 0, order_kept = 0, order_new = 0;
  for (std::size_t k = 0; k < base_runs.size(); ++k) {
    if (base_runs[k] < 0) return "negative base run " + std::to_string(k);
    base_total += base_runs[k];
    if (k % 2 == 0) kept += base_runs[k];
  }
  if (base_total != static_cast<std::int64_t>(base.size())) {
    return "base runs sum to " + std::to_string(base_total) + " points, the base holds " + std::to_string(base.size());
  }
  for (std::size_t k = 0; k < order_runs.size(); ++k) {
    if (order_runs[k] < 0) return "negative order run " + std::to_string(k);
    (k % 2 == 0 ? order_kept : order_new) += order_runs[k];
  }
  if (order_kept != kept) {
    return "order runs keep " + std::to_string(order_kept) + " points, base runs " + std::to_string(kept);
  }
  if (order_new != static_cast<std::int64_t>(new_points.size())) {
    return "order runs place " + std::to_string(order_new) + " new points, the message holds " +
           std::to_string(new_points.size());
  }
  out.reserve(static_cast<std::size_t>(kept + order_new));
  std::size_t base_run = 0, base_at = 0, left_in_run = base_runs.empty() ? 0 : static_cast<std::size_t>(base_runs[0]);
  std::size_t next_new = 0;
  // The next kept base point: skips the left-out runs (and empty kept runs) on the way.
  const auto take_kept = [&]() {
    while (left_in_run == 0) {
      base_at += base_run % 2 == 0 ? 0 : static_cast<std::size_t>(base_runs[base_run]);
      ++base_run;
      left_in_run = base_run % 2 == 0 ? static_cast<std::size_t>(base_runs[base_run]) : 0;
    }
    out.push_back(base.positions[base_at], base.colors[base_at]);
    ++base_at;
    --left_in_run;
  };
  for (std::size_t k = 0; k < order_runs.size(); ++k) {
    for (std::int32_t n = 0; n < order_runs[k]; ++n) {
      if (k % 2 == 0) {
        take_kept();
      } else {
        out.push_back(new_points.positions[next_new], new_points.colors[next_new]);
        ++next_new;
      }
    }
  }
  return std::nullopt;
}

}  // namespace mfot::service
