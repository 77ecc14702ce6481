#include "script.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace mfot::sim::detail {

namespace {

constexpr float kPi = 3.14159265f;
constexpr float kPalmHalfLength = 0.05f;
constexpr float kPalmHalfThickness = 0.015f;

double round_up_to_frames(double seconds) { return std::ceil(seconds * kFps - 1e-6) / kFps; }

}  // namespace

double progress(Profile profile, double tau) {
  switch (profile) {
    case Profile::linear:
      return tau;
    case Profile::ease_in:
      return tau * tau;
    case Profile::ease_out:
      return tau * (2.0 - tau);
    case Profile::eased:
      break;
  }
  return tau * tau * (3.0 - 2.0 * tau);
}

Iso interpolate(const Iso& a, const Iso& b, const Eigen::Vector3f& pivot, double tau, Profile profile) {
  const auto s = static_cast<float>(progress(profile, tau));
  const Eigen::Quaternionf qa(a.rotation()), qb(b.rotation());
  const Eigen::Quaternionf q = qa.slerp(s, qb).normalized();
  const Eigen::Vector3f pa = a * pivot, pb = b * pivot;
  Iso out = Iso::Identity();
  out.linear() = q.toRotationMatrix();
  out.translation() = pa + s * (pb - pa) - q * pivot;
  return out;
}

double min_move_duration(const Iso& a, const Iso& b, const Eigen::Vector3f& pivot) {
  // Peak speeds of a unit-duration move, sampled; both scale with 1 / duration.
  constexpr int kSteps = 64;
  double peak_linear = 0.0;
  Iso prev = a;
  for (int k = 1; k <= kSteps; ++k) {
    const Iso cur = interpolate(a, b, pivot, static_cast<double>(k) / kSteps);
    const double origin = (cur.translation() - prev.translation()).norm();
    const double centre = (cur * pivot - prev * pivot).norm();
    peak_linear = std::max(peak_linear, std::max(origin, centre) * kSteps);
    prev = cur;
  }
  const double angle = Eigen::AngleAxisf(a.rotation().transpose() * b.rotation()).angle();
  const double peak_angular = 1.5 * std::abs(angle);
  return std::max(peak_linear / kMaxLinearSpeed, peak_angular / kMaxAngularSpeed);
}

Iso pose_at(const Script& script, int b, double t) {
  const BodyScript& body = script.bodies[b];
  for (const Attachment& a : body.attachments) {
    if (t >= a.t0 && t < a.t1) return pose_at(script, a.carrier, t) * a.offset;
  }
  const auto& keys = body.keys;
  if (keys.empty()) return Iso::Identity();
  if (t <= keys.front().t) return keys.front().pose;
  if (t >= keys.back().t) return keys.back().pose;
  const auto next = std::upper_bound(keys.begin(), keys.end(), t, [](double v, const Keyframe& k) { return v < k.t; });
  const Keyframe& k1 = *next;
  const Keyframe& k0 = *(next - 1);
  return interpolate(k0.pose, k1.pose, k1.pivot, (t - k0.t) / (k1.t - k0.t), k1.profile);
}

int ScriptBuilder::add_body(BodyInfo info, const Iso& world_pose) {
  BodyScript body;
  body.info = std::move(info);
  body.keys.push_back({0.0, world_pose, Eigen::Vector3f::Zero()});
  script_.bodies.push_back(std::move(body));
  current_.push_back(world_pose);
  carried_by_.push_back(-1);
  carrying_.push_back(-1);
  return static_cast<int>(current_.size()) - 1;
}

void ScriptBuilder::key(int body, double t, const Iso& pose, Profile profile) {
  auto& keys = script_.bodies[body].keys;
  if (!keys.empty() && t < keys.back().t) throw std::logic_error("ScriptBuilder::key: keyframes out of order");
  const Eigen::Vector3f pivot =
      carrying_[body] >= 0 ? Eigen::Vector3f(script_.bodies[carrying_[body]].attachments.back().offset.translation())
                           : Eigen::Vector3f::Zero();
  keys.push_back({t, pose, pivot, profile});
  current_[body] = pose;
}

double ScriptBuilder::move(const std::vector<Target>& targets, double min_duration_s) {
  double duration = min_duration_s;
  for (const Target& target : targets) {
    if (carried_by_[target.body] >= 0)
      throw std::logic_error("ScriptBuilder::move: a carried body moves with its hand");
    const int obj = carrying_[target.body];
    const Eigen::Vector3f pivot = obj >= 0
                                      ? Eigen::Vector3f(script_.bodies[obj].attachments.back().offset.translation())
                                      : Eigen::Vector3f::Zero();
    duration = std::max(duration, min_move_duration(current_[target.body], target.pose, pivot));
  }
  duration = round_up_to_frames(duration);
  for (const Target& target : targets) {
    key(target.body, now_, current_[target.body]);
    key(target.body, now_ + duration, target.pose);
    const int obj = carrying_[target.body];
    if (obj >= 0) current_[obj] = target.pose * script_.bodies[obj].attachments.back().offset;
  }
  now_ += duration;
  return duration;
}

Iso ScriptBuilder::hand_target_for(int hand, const Iso& object_pose) const {
  const int obj = carrying_[hand];
  if (obj < 0) throw std::logic_error("ScriptBuilder::hand_target_for: hand carries nothing");
  return object_pose * script_.bodies[obj].attachments.back().offset.inverse();
}

void ScriptBuilder::grasp(int hand, int object) {
  if (carrying_[hand] >= 0 || carried_by_[object] >= 0) throw std::logic_error("ScriptBuilder::grasp: already held");
  key(object, now_, current_[object]);
  script_.bodies[object].attachments.push_back(
      {hand, now_, std::numeric_limits<double>::infinity(), current_[hand].inverse() * current_[object]});
  carried_by_[object] = hand;
  carrying_[hand] = object;
}

void ScriptBuilder::release(int hand) {
  const int obj = carrying_[hand];
  if (obj < 0) throw std::logic_error("ScriptBuilder::release: hand carries nothing");
  script_.bodies[obj].attachments.back().t1 = now_;
  carrying_[hand] = -1;
  carried_by_[obj] = -1;
  key(obj, now_, current_[obj]);
}

void ScriptBuilder::wait(double seconds) { now_ += round_up_to_frames(seconds); }

Script ScriptBuilder::finish(double extra_wait_s) {
  wait(extra_wait_s);
  script_.duration_s = now_;
  return std::move(script_);
}

BodyInfo make_box(int id, const Eigen::Vector3f& size, const std::array<Rgb8, 6>& faces, Pattern pattern,
                  Rgb8 pattern_color, float period_m) {
  Primitive p;
  p.kind = PrimitiveKind::box;
  p.size = size;
  p.face_colors = faces;
  p.pattern = pattern;
  p.pattern_color = pattern_color;
  p.pattern_period_m = period_m;
  p.label = static_cast<std::uint16_t>(id);
  return {id, false, {p}};
}

BodyInfo make_can(int id, float diameter, float height, Rgb8 side, Rgb8 stripe, Rgb8 caps, float period_m) {
  Primitive p;
  p.kind = PrimitiveKind::cylinder;
  p.size = Eigen::Vector3f(diameter, diameter, height);
  p.face_colors = {side, side, side, side, caps, caps};
  p.pattern = Pattern::stripes;
  p.pattern_color = stripe;
  p.pattern_period_m = period_m;
  p.label = static_cast<std::uint16_t>(id);
  return {id, false, {p}, Eigen::Vector3f::UnitZ()};  // the cylinder's axis
}

BodyInfo make_hand(int id, const Eigen::Vector3f& up_local) {
  const Rgb8 skin{222, 176, 146}, skin_dark{205, 158, 128}, sleeve{46, 62, 110};
  const auto label = static_cast<std::uint16_t>(id);
  BodyInfo hand{id, true, {}};

  Primitive palm;
  palm.kind = PrimitiveKind::box;
  palm.size = Eigen::Vector3f(2.0f * kPalmHalfLength, 0.08f, 2.0f * kPalmHalfThickness);
  palm.face_colors = {skin, skin, skin, skin, skin_dark, skin};
  palm.label = label;
  hand.primitives.push_back(palm);

  // Fingers bent down 45 degrees about the palm's front-bottom edge, their palm side facing back
  // and down so they hang over the far face of a grasped object without entering it.
  Primitive fingers = palm;
  fingers.size = Eigen::Vector3f(0.08f, 0.075f, 0.02f);
  const Eigen::Matrix3f bend = Eigen::AngleAxisf(kPi / 4.0f, Eigen::Vector3f::UnitY()).toRotationMatrix();
  const Eigen::Vector3f hinge(kPalmHalfLength + 0.002f, 0.0f, -kPalmHalfThickness);
  fingers.pose.rotation = Eigen::Quaternionf(bend);
  fingers.pose.translation = hinge + bend * Eigen::Vector3f(0.04f, 0.0f, 0.01f);
  hand.primitives.push_back(fingers);

  // Forearm (skin) then upper arm (sleeve) as one straight limb rising 20 degrees from the wrist.
  const Eigen::Vector3f dir = -std::cos(20.0f * kPi / 180.0f) * Eigen::Vector3f::UnitX() +
                              std::sin(20.0f * kPi / 180.0f) * up_local.normalized();
  const Eigen::Quaternionf along = Eigen::Quaternionf::FromTwoVectors(Eigen::Vector3f::UnitZ(), dir);
  const Eigen::Vector3f wrist(-kPalmHalfLength, 0.0f, 0.025f);
  Primitive forearm;
  forearm.kind = PrimitiveKind::cylinder;
  forearm.size = Eigen::Vector3f(0.07f, 0.07f, 0.28f);
  forearm.pose.rotation = along;
  forearm.pose.translation = wrist + dir * 0.14f;
  forearm.face_colors = {skin_dark, skin_dark, skin_dark, skin_dark, skin_dark, skin_dark};
  forearm.label = label;
  hand.primitives.push_back(forearm);
  Primitive upper = forearm;
  upper.size = Eigen::Vector3f(0.09f, 0.09f, 0.32f);
  upper.pose.translation = wrist + dir * (0.28f + 0.16f);
  upper.face_colors = {sleeve, sleeve, sleeve, sleeve, sleeve, sleeve};
  hand.primitives.push_back(upper);
  return hand;
}

Iso side_grasp(const BodyInfo& object, const Iso& object_pose, float side) {
  const Primitive& p = object.primitives.front();
  const Eigen::Vector3f half = 0.5f * p.size;
  const float half_x = half.x();
  const float half_y = p.kind == PrimitiveKind::box ? half.y() : half.x();
  // Hand axes in the object frame: fingers +y, back of the hand outwards (side * x), y = z x x.
  const Eigen::Vector3f x_h = Eigen::Vector3f::UnitY(), z_h = side * Eigen::Vector3f::UnitX();
  Eigen::Matrix3f axes;
  axes << x_h, z_h.cross(x_h), z_h;
  Iso local = Iso::Identity();
  local.linear() = axes;
  local.translation() = Eigen::Vector3f(side * (half_x + kPalmHalfThickness), half_y - kPalmHalfLength - 0.002f, 0.0f);
  return object_pose * local;
}

float half_height(const BodyInfo& object) {
  float out = 0.0f;
  for (const Primitive& p : object.primitives)
    out = std::max(out, std::abs(p.pose.translation.z()) + 0.5f * p.size.z());
  return out;
}

float footprint_radius(const BodyInfo& object) {
  float out = 0.0f;
  for (const Primitive& p : object.primitives) {
    const float own = p.kind == PrimitiveKind::box ? 0.5f * std::hypot(p.size.x(), p.size.y()) : 0.5f * p.size.x();
    out = std::max(out, p.pose.translation.head<2>().norm() + own);
  }
  return out;
}

Eigen::Vector3f half_extents(const BodyInfo& object) {
  Eigen::Vector3f out = Eigen::Vector3f::Zero();
  for (const Primitive& p : object.primitives) out = out.cwiseMax(p.pose.translation.cwiseAbs() + 0.5f * p.size);
  return out;
}

Iso top_grasp(const BodyInfo& object, const Iso& object_pose, float yaw) {
  const Primitive& p = object.primitives.front();
  const float c = std::cos(yaw), s = std::sin(yaw);
  const float extent =
      p.kind == PrimitiveKind::box ? 0.5f * (std::abs(c) * p.size.x() + std::abs(s) * p.size.y()) : 0.5f * p.size.x();
  const float forward = std::max(0.0f, extent - kPalmHalfLength);
  Iso local = Iso::Identity();
  local.linear() = Eigen::AngleAxisf(yaw, Eigen::Vector3f::UnitZ()).toRotationMatrix();
  local.translation() = Eigen::Vector3f(forward * c, forward * s, half_height(object) + kPalmHalfThickness);
  return object_pose * local;
}

}  // namespace mfot::sim::detail
