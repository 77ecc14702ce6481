#include "mfot/companion_motion.hpp"

#include <numbers>

#include "mfot/option_range.hpp"
#include "mfot/particle_filter.hpp"

namespace mfot {

void CompanionOptions::validate() const {
  require_in_range("CompanionOptions", "contact_distance", contact_distance, 0, 0.1, false);
  require_in_range("CompanionOptions", "min_motion", min_motion, 0, 1, true);
  require_in_range("CompanionOptions", "min_turn_deg", min_turn_deg, 0, 180, true);
}

PoseVector companion_increment(const Pose& pose, const Pose& companion_pose, const PoseVector& companion_velocity) {
  // The companion's dX applied once more (2.15: its origin moves by the translation, the body turns
  // about its origin) moves a point rigidly attached to it from p to c + v + R (p - c); for this
  // object's origin that is its translation increment, and the turn is the same.
  const Eigen::Quaternionf turn = rotation_from_rpy(companion_velocity.tail<3>());
  const Eigen::Vector3f offset = pose.translation - companion_pose.translation;
  PoseVector increment;
  increment.head<3>() = companion_velocity.head<3>() + turn * offset - offset;
  increment.tail<3>() = companion_velocity.tail<3>();
  return increment;
}

namespace {

float turn_angle(const PoseVector& increment) {
  return Eigen::AngleAxisf(rotation_from_rpy(increment.tail<3>())).angle();
}

}  // namespace

bool companion_moved(const PoseVector& velocity, const CompanionOptions& options) {
  return velocity.head<3>().norm() >= options.min_motion ||
         turn_angle(velocity) >= options.min_turn_deg * std::numbers::pi_v<float> / 180.f;
}

float increment_reach(const PoseVector& increment, float radius) {
  return increment.head<3>().norm() + turn_angle(increment) * radius;
}

}  // namespace mfot
