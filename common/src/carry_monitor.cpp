// Objects carried while hidden (steps in the header).

#include "mfot/carry_monitor.hpp"

#include <algorithm>
#include <limits>
#include <numbers>
#include <tuple>

#include "mfot/option_range.hpp"

namespace mfot {

void CarryOptions::validate() const {
  const auto in = [](const char* field, auto value, double low, double high, bool low_open) {
    require_in_range("CarryOptions", field, value, low, high, low_open);
  };
  in("frames", frames, 0, 10000, false);
  in("translation", translation, 0, 0.5, true);
  in("rotation_deg", rotation_deg, 0, 90, true);
  in("min_motion", min_motion, 0, 1, true);
  in("min_turn_deg", min_turn_deg, 0, 180, true);
  in("contact_distance", contact_distance, 0, 0.1, true);
  in("seen_through_share", seen_through_share, 0, 1, false);
  in("carried_seen_through_share", carried_seen_through_share, 0, 1, false);
}

namespace {

const CarryOptions& validated(const CarryOptions& options) {
  options.validate();
  return options;
}

float radians(float degrees) { return degrees * std::numbers::pi_v<float> / 180.f; }

// How far an object went from before to now, in units of min_motion and min_turn_deg (the larger of
// the two): at least 1 = it moved.
float motion_units(const Pose& now, const Pose& before, const CarryOptions& options) {
  return std::max((now.translation - before.translation).norm() / options.min_motion,
                  now.rotation.angularDistance(before.rotation) / radians(options.min_turn_deg));
}

}  // namespace

CarryMonitor::CarryMonitor(const CarryOptions& options) : options_(validated(options)) {}

void CarryMonitor::observe(const Object& object, const Object& neighbour) {
  const Eigen::Isometry3f relative = neighbour.pose.isometry().inverse() * object.pose.isometry();
  Watch& watch = watches_[{object.id, neighbour.id}];
  bool kept = false;
  if (watch.frames > 0) {
    const Eigen::Isometry3f& before = watch.recent.front();
    const Eigen::AngleAxisf drift(Eigen::Quaternionf(before.linear().transpose() * relative.linear()));
    kept = (relative.translation() - before.translation()).norm() <= options_.translation &&
           drift.angle() <= radians(options_.rotation_deg);
  }
  if (!kept) {
    watch = Watch{.recent = {relative},
                  .neighbour_at_start = neighbour.pose,
                  .object_at_start = object.pose,
                  .last_seen = relative,
                  .frames = 1};
    return;
  }
  ++watch.frames;
  watch.last_seen = relative;
  watch.recent.push_back(relative);
  if (watch.recent.size() > static_cast<std::size_t>(options_.frames)) watch.recent.pop_front();
  watch.neighbour_moved =
      watch.neighbour_moved || motion_units(neighbour.pose, watch.neighbour_at_start, options_) >= 1.f;
  watch.object_moved = watch.object_moved || motion_units(object.pose, watch.object_at_start, options_) >= 1.f;
}

void CarryMonitor::observe_hidden(const Object& object, const Object& neighbour) {
  const auto [it, first] = hidden_watches_.try_emplace({object.id, neighbour.id});
  HiddenWatch& watch = it->second;
  ++watch.frames;
  if (watch.carrying) return;
  // The neighbour's step since the last touching frame: the least since the hidden watch began is the grip.
  const float step =
      first ? std::numeric_limits<float>::infinity() : motion_units(neighbour.pose, watch.neighbour_before, options_);
  watch.neighbour_before = neighbour.pose;
  if (!first && step > watch.grip_step) return;
  watch.grip_step = step;
  watch.relative = neighbour.pose.isometry().inverse() * object.pose.isometry();
  watch.neighbour_at_grip = neighbour.pose;
}

const CarryMonitor::Object* CarryMonitor::watched_carrier(const Object& object, std::span<const Object> objects,
                                                          Eigen::Isometry3f& relative) const {
  const Object* carrier = nullptr;
  const Watch* carrier_watch = nullptr;
  std::tuple<int, std::int32_t> best;  // the longest watch; ties: the lower id
  for (const Object& neighbour : objects) {
    if (neighbour.hidden || neighbour.id == object.id) continue;
    const auto it = watches_.find({object.id, neighbour.id});
    if (it == watches_.end() || it->second.frames < options_.frames || !it->second.neighbour_moved ||
        !it->second.object_moved) {
      continue;
    }
    const std::tuple<int, std::int32_t> rank{it->second.frames, -neighbour.id};
    if (carrier == nullptr || rank > best) {
      best = rank;
      carrier = &neighbour;
      carrier_watch = &it->second;
    }
  }
  if (carrier_watch != nullptr) relative = carrier_watch->last_seen;
  return carrier;
}

const CarryMonitor::Object* CarryMonitor::gripping_carrier(const Object& object, std::span<const Object> objects,
                                                           HiddenWatch** watch) {
  const Object* carrier = nullptr;
  *watch = nullptr;
  // A watch already carrying wins (the object goes on with the neighbour that took it), then the
  // longest; ties: the lower id.
  std::tuple<bool, int, std::int32_t> best;
  for (const Object& neighbour : objects) {
    if (neighbour.hidden || neighbour.id == object.id) continue;
    const auto it = hidden_watches_.find({object.id, neighbour.id});
    if (it == hidden_watches_.end()) continue;
    HiddenWatch& candidate = it->second;
    if (!candidate.carrying && motion_units(neighbour.pose, candidate.neighbour_at_grip, options_) < 1.f) continue;
    const std::tuple<bool, int, std::int32_t> rank{candidate.carrying, candidate.frames, -neighbour.id};
    if (carrier == nullptr || rank > best) {
      best = rank;
      carrier = &neighbour;
      *watch = &candidate;
    }
  }
  return carrier;
}

const std::vector<CarryMonitor::Carried>& CarryMonitor::update(std::span<const Object> objects, const TouchTest& touch,
                                                               const SeenThroughTest& seen_through) {
  carried_.clear();
  if (options_.frames == 0) return carried_;
  // 1. watches of the pairs seen this frame
  for (std::size_t a = 0; a < objects.size(); ++a) {
    if (objects[a].hidden) continue;
    for (std::size_t b = a + 1; b < objects.size(); ++b) {
      if (objects[b].hidden) continue;
      if (!touch(objects[a].id, objects[b].id)) {
        watches_.erase({objects[a].id, objects[b].id});
        watches_.erase({objects[b].id, objects[a].id});
        continue;
      }
      observe(objects[a], objects[b]);
      observe(objects[b], objects[a]);
    }
  }
  // 4. hidden watches: touching pairs of a hidden and a seen object; a seen object's go
  if (options_.seen_through_share > 0.f) {
    for (const Object& object : objects) {
      if (!object.hidden) {
        std::erase_if(hidden_watches_, [&](const auto& entry) { return entry.first.first == object.id; });
        continue;
      }
      for (const Object& neighbour : objects) {
        if (neighbour.hidden || neighbour.id == object.id) continue;
        if (touch(object.id, neighbour.id)) observe_hidden(object, neighbour);
      }
    }
  }
  // 2, 3, 5, 6. hidden objects and their carriers
  for (const Object& object : objects) {
    if (!object.hidden) continue;
    Eigen::Isometry3f relative;
    const Object* carrier = watched_carrier(object, objects, relative);
    bool gripped_away = false;
    if (carrier == nullptr && options_.seen_through_share > 0.f) {
      HiddenWatch* watch = nullptr;
      carrier = gripping_carrier(object, objects, &watch);
      const auto taken = [&] {
        return seen_through(object.id, object.pose) >= options_.seen_through_share &&
               seen_through(object.id, Pose::from_isometry(carrier->pose.isometry() * watch->relative)) <=
                   options_.carried_seen_through_share;
      };
      if (carrier != nullptr && (watch->carrying || taken())) {
        watch->carrying = true;
        gripped_away = true;
      } else {
        carrier = nullptr;
      }
    }
    if (carrier == nullptr) continue;
    if (gripped_away) {
      carried_.push_back({object.id, carrier->id, object.pose, true});
    } else {
      carried_.push_back({object.id, carrier->id, Pose::from_isometry(carrier->pose.isometry() * relative), false});
    }
  }
  std::sort(carried_.begin(), carried_.end(), [](const Carried& x, const Carried& y) { return x.id < y.id; });
  return carried_;
}

void CarryMonitor::forget(std::int32_t id) {
  const auto involves = [id](const auto& entry) { return entry.first.first == id || entry.first.second == id; };
  std::erase_if(watches_, involves);
  std::erase_if(hidden_watches_, involves);
}

}  // namespace mfot
