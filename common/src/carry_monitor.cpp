// Objects carried while hidden (steps in the header).

#include "mfot/carry_monitor.hpp"

#include "mfot/option_range.hpp"

#include <algorithm>
#include <numbers>

namespace mfot {

void CarryOptions::validate() const {
  const auto in = [](const char* field, double value, double low, double high, bool low_open) {
    require_in_range("CarryOptions", field, value, low, high, low_open);
  };
  in("frames", frames, 0, 10000, false);
  in("translation", translation, 0, 0.5, true);
  in("rotation_deg", rotation_deg, 0, 90, true);
  in("min_motion", min_motion, 0, 1, true);
  in("min_turn_deg", min_turn_deg, 0, 180, true);
  in("contact_distance", contact_distance, 0, 0.1, true);
}

namespace {

const CarryOptions& validated(const CarryOptions& options) {
  options.validate();
  return options;
}

float radians(float degrees) { return degrees * std::numbers::pi_v<float> / 180.f; }

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
    watch = Watch{{relative}, neighbour.pose, relative, 1, false};
    return;
  }
  ++watch.frames;
  watch.last_seen = relative;
  watch.recent.push_back(relative);
  if (watch.recent.size() > static_cast<std::size_t>(options_.frames)) watch.recent.pop_front();
  watch.neighbour_moved =
      watch.neighbour_moved ||
      (neighbour.pose.translation - watch.neighbour_at_start.translation).norm() >= options_.min_motion ||
      neighbour.pose.rotation.angularDistance(watch.neighbour_at_start.rotation) >= radians(options_.min_turn_deg);
}

const std::vector<CarryMonitor::Carried>& CarryMonitor::update(std::span<const Object> objects, const TouchTest& touch) {
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
  // 2, 3. hidden objects and their carriers
  for (const Object& object : objects) {
    if (!object.hidden) continue;
    const Object* carrier = nullptr;
    const Watch* carrier_watch = nullptr;
    for (const Object& neighbour : objects) {
      if (neighbour.hidden || neighbour.id == object.id) continue;
      const auto it = watches_.find({object.id, neighbour.id});
      if (it == watches_.end() || it->second.frames < options_.frames || !it->second.neighbour_moved) continue;
      const bool better = carrier_watch == nullptr || it->second.frames > carrier_watch->frames ||
                          (it->second.frames == carrier_watch->frames && neighbour.id < carrier->id);
      if (better) {
        carrier = &neighbour;
        carrier_watch = &it->second;
      }
    }
    if (carrier != nullptr) {
      carried_.push_back({object.id, carrier->id, Pose::from_isometry(carrier->pose.isometry() * carrier_watch->last_seen)});
    }
  }
  std::sort(carried_.begin(), carried_.end(), [](const Carried& x, const Carried& y) { return x.id < y.id; });
  return carried_;
}

void CarryMonitor::forget(std::int32_t id) {
  std::erase_if(watches_, [id](const auto& entry) { return entry.first.first == id || entry.first.second == id; });
}

}  // namespace mfot
