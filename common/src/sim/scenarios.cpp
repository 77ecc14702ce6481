// The simulator's scenarios (thesis chapter 4's experiments, a seeded random scene and seeded
// hands-free rotation scenes).
//
// Layout conventions: world z = 0 is the table top, objects stand upright on it (centre height =
// half height) or on each other, and every pair of objects present at frame 0 is at least 4 cm
// apart, except in `apart`, whose objects start stacked and touching. Hands wait outside the image at frame 0, reach
// in, grasp from above (palm on the top face, fingers over a side face) and carry objects rigidly; in the hands-free
// scenarios objects move by keyframes alone. Contacts are exact to 0.5 mm (touching, never overlapping).

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "script.hpp"

namespace mfot::sim::detail {

namespace {

constexpr float kPi = 3.14159265f;

Iso at(float x, float y, float z, float yaw = 0.0f) {
  Iso t = Iso::Identity();
  t.linear() = Eigen::AngleAxisf(yaw, Eigen::Vector3f::UnitZ()).toRotationMatrix();
  t.translation() = Eigen::Vector3f(x, y, z);
  return t;
}

Iso raised(const Iso& pose, float dz) {
  Iso t = pose;
  t.translation().z() += dz;
  return t;
}

// pose rotated by r about its own origin, r given in world axes.
Iso turned(const Iso& pose, const Eigen::Matrix3f& r) {
  Iso t = pose;
  t.linear() = r * pose.linear();
  return t;
}

Eigen::Matrix3f rot(float angle_deg, const Eigen::Vector3f& axis) {
  return Eigen::AngleAxisf(angle_deg * kPi / 180.0f, axis).toRotationMatrix();
}

constexpr float kApproach = 0.08f;  // hover height above a grasp or placement, metres

// Hand comes above the object, descends, grasps, lifts it above everything on the way, carries
// it to target (resting pose), lowers it, releases and rises again.
void pick_and_place(ScriptBuilder& b, const Script& bodies_of, int hand, int object, float grasp_yaw, const Iso& target,
                    float clear_height) {
  const BodyInfo& info = bodies_of.bodies[object].info;
  const Iso grasp = top_grasp(info, b.pose(object), grasp_yaw);
  b.move({{hand, raised(grasp, kApproach)}});
  b.move({{hand, grasp}});
  b.wait(0.3);
  b.grasp(hand, object);
  const float lift_z = std::max(b.pose(object).translation().z(), target.translation().z()) + clear_height;
  Iso lifted = b.pose(object);
  lifted.translation().z() = lift_z;
  b.move({{hand, b.hand_target_for(hand, lifted)}});
  Iso above = target;
  above.translation().z() = lift_z;
  b.move({{hand, b.hand_target_for(hand, above)}});
  b.move({{hand, b.hand_target_for(hand, target)}});
  b.wait(0.3);
  b.release(hand);
  b.move({{hand, raised(b.pose(hand), kApproach)}});
}

// ScriptBuilder keeps the bodies inside its script; a snapshot lets helpers read body geometry.
struct Bodies {
  Script infos;
  int add(ScriptBuilder& b, BodyInfo info, const Iso& pose) {
    infos.bodies.push_back({info, {}, {}});
    return b.add_body(std::move(info), pose);
  }
};

Script stack_scenario() {
  ScriptBuilder b;
  Bodies s;
  const int top = s.add(b, make_box(1, {0.07f, 0.06f, 0.09f}, {kRed, kGreen, kBlue, kYellow, kMagenta, kCyan}),
                        at(-0.18f, 0.05f, 0.045f));
  const int base = s.add(b,
                         make_box(2, {0.16f, 0.12f, 0.07f}, {kOrange, kPurple, kLime, kPink, kWhite, kBlack},
                                  Pattern::stripes, kWhite, 0.04f),
                         at(0.10f, 0.05f, 0.035f));
  s.add(b, make_can(3, 0.066f, 0.12f, kRed, kWhite, kGrey), at(-0.02f, 0.30f, 0.06f));
  const Iso home = at(-0.75f, 0.05f, 0.35f);
  const int hand = s.add(b, make_hand(101), home);

  b.wait(1.0);
  const float top_half = half_height(s.infos.bodies[top].info);
  const Eigen::Vector3f base_centre = b.pose(base).translation();
  const float base_top = base_centre.z() + half_height(s.infos.bodies[base].info);
  pick_and_place(b, s.infos, hand, top, 0.0f,
                 at(base_centre.x(), base_centre.y(), base_top + top_half, 30.0f * kPi / 180.0f), 0.06f);
  b.move({{hand, home}});
  b.wait(1.2);
  pick_and_place(b, s.infos, hand, top, 0.0f, at(-0.16f, -0.04f, top_half), 0.06f);
  b.move({{hand, home}});
  return b.finish(0.8);
}

Script contact_scenario() {
  ScriptBuilder b;
  Bodies s;
  const Eigen::Vector3f left_size(0.08f, 0.08f, 0.10f), right_size(0.10f, 0.07f, 0.09f);
  const int left =
      s.add(b, make_box(1, left_size, {kBlue, kYellow, kRed, kGreen, kWhite, kBlack}, Pattern::checker, kWhite, 0.04f),
            at(-0.20f, 0.10f, 0.5f * left_size.z()));
  const int right = s.add(b, make_box(2, right_size, {kOrange, kCyan, kMagenta, kLime, kPurple, kPink}),
                          at(0.20f, 0.10f, 0.5f * right_size.z()));
  s.add(b, make_can(3, 0.06f, 0.10f, kGreen, kYellow, kGrey), at(0.02f, 0.40f, 0.05f));
  // Hands come from the image sides and hold the objects by their outer faces, so the faces
  // that meet stay free; the arms lead back towards the camera.
  const Iso grasp_l = side_grasp(s.infos.bodies[left].info, b.pose(left), -1.0f);
  const Iso grasp_r = side_grasp(s.infos.bodies[right].info, b.pose(right), 1.0f);
  auto shifted = [](const Iso& pose, float dx) {
    Iso t = pose;
    t.translation().x() += dx;
    return t;
  };
  const Iso left_home = shifted(grasp_l, -0.50f), right_home = shifted(grasp_r, 0.50f);
  const int hand_l = s.add(b, make_hand(101, {0.0f, -1.0f, 0.0f}), left_home);
  const int hand_r = s.add(b, make_hand(102, {0.0f, 1.0f, 0.0f}), right_home);

  b.wait(1.0);
  b.move({{hand_l, shifted(grasp_l, -kApproach)}, {hand_r, shifted(grasp_r, kApproach)}});
  b.move({{hand_l, grasp_l}, {hand_r, grasp_r}});
  b.wait(0.3);
  b.grasp(hand_l, left);
  b.grasp(hand_r, right);

  // Slide both along the table until their faces touch at x = dx.
  const float gap = 0.0005f;
  auto both_to = [&](float dx, float dy, float min_duration) {
    const Iso l = at(-0.5f * left_size.x() - gap + dx, 0.10f + dy, 0.5f * left_size.z());
    const Iso r = at(0.5f * right_size.x() + gap + dx, 0.10f + dy, 0.5f * right_size.z());
    b.move({{hand_l, b.hand_target_for(hand_l, l)}, {hand_r, b.hand_target_for(hand_r, r)}}, min_duration);
  };
  both_to(0.0f, 0.0f, 0.8);
  b.wait(0.5);
  both_to(0.0f, 0.12f, 0.8);  // pushed together, away from the camera
  both_to(0.08f, 0.06f, 0.8);
  both_to(-0.06f, 0.0f, 0.8);
  both_to(0.0f, 0.0f, 0.8);
  b.wait(0.5);
  // Apart again, release, leave.
  b.move({{hand_l, b.hand_target_for(hand_l, b.scripted_pose(left, 0.0))},
          {hand_r, b.hand_target_for(hand_r, b.scripted_pose(right, 0.0))}});
  b.wait(0.3);
  b.release(hand_l);
  b.release(hand_r);
  b.move({{hand_l, shifted(b.pose(hand_l), -kApproach)}, {hand_r, shifted(b.pose(hand_r), kApproach)}});
  b.move({{hand_l, left_home}, {hand_r, right_home}});
  return b.finish(0.8);
}

Script rotate_scenario() {
  ScriptBuilder b;
  Bodies s;
  const Eigen::Vector3f size(0.10f, 0.07f, 0.12f);
  const int box =
      s.add(b, make_box(1, size, {kRed, kGreen, kBlue, kYellow, kMagenta, kCyan}), at(0.0f, 0.08f, 0.5f * size.z()));
  s.add(b, make_can(2, 0.07f, 0.11f, kOrange, kBlack, kGrey), at(0.24f, 0.28f, 0.055f));
  const Iso home = at(-0.75f, 0.08f, 0.35f);
  const int hand = s.add(b, make_hand(101), home);

  b.wait(1.0);
  const Iso grasp = top_grasp(s.infos.bodies[box].info, b.pose(box), 0.0f);
  b.move({{hand, raised(grasp, kApproach)}});
  b.move({{hand, grasp}});
  b.wait(0.3);
  b.grasp(hand, box);
  const Iso rest = b.pose(box);
  const Iso lifted = raised(rest, 0.16f);
  b.move({{hand, b.hand_target_for(hand, lifted)}});
  b.wait(0.3);
  // About each world axis in turn and back; signs keep the rigid arm above the table.
  const std::array<Eigen::Matrix3f, 3> turns{rot(60.0f, Eigen::Vector3f::UnitX()), rot(45.0f, Eigen::Vector3f::UnitY()),
                                             rot(-90.0f, Eigen::Vector3f::UnitZ())};
  for (const Eigen::Matrix3f& r : turns) {
    b.move({{hand, b.hand_target_for(hand, turned(lifted, r))}});
    b.wait(0.3);
    b.move({{hand, b.hand_target_for(hand, lifted)}});
    b.wait(0.3);
  }
  // A combined turn (all three axes at once) and back.
  const Eigen::Matrix3f combined = rot(-60.0f, Eigen::Vector3f::UnitZ()) * rot(30.0f, Eigen::Vector3f::UnitY()) *
                                   rot(40.0f, Eigen::Vector3f::UnitX());
  b.move({{hand, b.hand_target_for(hand, turned(lifted, combined))}});
  b.wait(0.3);
  b.move({{hand, b.hand_target_for(hand, lifted)}});
  b.move({{hand, b.hand_target_for(hand, rest)}});
  b.wait(0.3);
  b.release(hand);
  b.move({{hand, raised(b.pose(hand), kApproach)}});
  b.move({{hand, home}});
  return b.finish(0.8);
}

Script static_scenario() {
  ScriptBuilder b;
  b.add_body(make_box(1, {0.08f, 0.06f, 0.12f}, {kRed, kGreen, kBlue, kYellow, kMagenta, kCyan}),
             at(-0.20f, 0.12f, 0.06f, 20.0f * kPi / 180.0f));
  b.add_body(make_can(2, 0.066f, 0.12f, kBlue, kWhite, kGrey), at(0.02f, 0.02f, 0.06f));
  b.add_body(make_box(3, {0.14f, 0.10f, 0.06f}, {kOrange, kPurple, kLime, kPink, kWhite, kBlack}, Pattern::checker,
                      kBlack, 0.04f),
             at(0.20f, 0.20f, 0.03f, -15.0f * kPi / 180.0f));
  return b.finish(10.0);
}

BodyInfo random_object(Draw& draw, int id, float scale) {
  std::array<Rgb8, kPalette.size()> colours = kPalette;
  for (int i = static_cast<int>(colours.size()) - 1; i > 0; --i) std::swap(colours[i], colours[draw.index(i + 1)]);
  if (draw(0.0, 1.0) < 0.65) {
    const Eigen::Vector3f size(draw.f(0.05, 0.14) * scale, draw.f(0.05, 0.14) * scale, draw.f(0.05, 0.20) * scale);
    const auto pattern = static_cast<Pattern>(draw.index(3));
    return make_box(id, size.cwiseMax(0.05f), {colours[0], colours[1], colours[2], colours[3], colours[4], colours[5]},
                    pattern, colours[6], draw.f(0.03, 0.06));
  }
  return make_can(id, std::max(0.05f, draw.f(0.05, 0.10) * scale), std::max(0.06f, draw.f(0.06, 0.20) * scale),
                  colours[0], colours[1], colours[2], draw.f(0.02, 0.05));
}

// Smallest distance over s in [0, 1] between points a0 + s (a1 - a0) and b0 + s (b1 - b0).
float closest_approach(const Eigen::Vector2f& a0, const Eigen::Vector2f& a1, const Eigen::Vector2f& b0,
                       const Eigen::Vector2f& b1) {
  const Eigen::Vector2f d0 = a0 - b0, dd = (a1 - b1) - d0;
  const float len2 = dd.squaredNorm();
  const float s = len2 > 0.0f ? std::clamp(-d0.dot(dd) / len2, 0.0f, 1.0f) : 0.0f;
  return (d0 + s * dd).norm();
}

constexpr std::uint64_t kGolden = 0x9e3779b97f4a7c15ULL;

Script random_scenario(const ScenarioOptions& o, int attempt) {
  Draw draw(o.seed * kGolden + static_cast<std::uint64_t>(attempt) + 0x5eedULL);
  const double duration = (o.num_frames > 0 ? o.num_frames : 600) / kFps;
  constexpr float kXMin = -0.34f, kXMax = 0.34f, kYMin = -0.16f, kYMax = 0.40f;
  ScriptBuilder b;

  struct Placed {
    int body;
    float radius, half_height;
    Eigen::Vector2f xy;
    float yaw;
  };
  std::vector<Placed> objects;
  float scale = 1.0f;
  for (int id = 1; id <= o.num_objects; ++id) {
    for (;;) {
      const BodyInfo info = random_object(draw, id, scale);
      const float r = footprint_radius(info);
      bool placed = false;
      for (int tries = 0; tries < 200 && !placed; ++tries) {
        const Eigen::Vector2f xy(draw.f(kXMin + r, kXMax - r), draw.f(kYMin + r, kYMax - r));
        placed = std::all_of(objects.begin(), objects.end(),
                             [&](const Placed& p) { return (p.xy - xy).norm() >= p.radius + r + 0.04f; });
        if (placed) {
          const float yaw = draw.f(-kPi, kPi);
          const int body = b.add_body(info, at(xy.x(), xy.y(), half_height(info), yaw));
          objects.push_back({body, r, half_height(info), xy, yaw});
        }
      }
      if (placed) break;
      scale *= 0.85f;  // crowded table: smaller objects
    }
  }

  // Objects slide in common phases; each mover's straight path keeps 1.5 cm clear of every other
  // object's path in the same phase (positions are linear in the common ease parameter).
  double t = 1.0;
  while (t < duration) {
    const double phase = draw(1.5, 3.0);
    std::vector<Eigen::Vector2f> from(objects.size()), to(objects.size());
    std::vector<float> yaw_to(objects.size());
    for (std::size_t i = 0; i < objects.size(); ++i) from[i] = to[i] = objects[i].xy, yaw_to[i] = objects[i].yaw;
    for (std::size_t i = 0; i < objects.size(); ++i) {
      if (draw(0.0, 1.0) >= 0.6) continue;
      const float dist = static_cast<float>(o.speed * phase);
      const float max_turn = std::min(kPi / 4.0f, static_cast<float>(0.8 * phase));
      for (int tries = 0; tries < 8; ++tries) {
        const float heading = draw.f(-kPi, kPi);
        const Eigen::Vector2f target = from[i] + dist * Eigen::Vector2f(std::cos(heading), std::sin(heading));
        const float turn = draw.f(-max_turn, max_turn);
        const float r = objects[i].radius;
        if (target.x() < kXMin + r || target.x() > kXMax - r || target.y() < kYMin + r || target.y() > kYMax - r)
          continue;
        bool clear = true;
        for (std::size_t j = 0; j < objects.size() && clear; ++j) {
          if (j == i) continue;
          clear = closest_approach(from[i], target, from[j], to[j]) >= r + objects[j].radius + 0.015f;
        }
        if (clear) {
          to[i] = target;
          yaw_to[i] = objects[i].yaw + turn;
          break;
        }
      }
    }
    for (std::size_t i = 0; i < objects.size(); ++i) {
      if (to[i] == from[i]) continue;
      Placed& p = objects[i];
      b.key(p.body, t, at(p.xy.x(), p.xy.y(), p.half_height, p.yaw));
      p.xy = to[i];
      p.yaw = yaw_to[i];
      b.key(p.body, t + phase, at(p.xy.x(), p.xy.y(), p.half_height, p.yaw));
    }
    t += phase + draw(0.3, 1.5);
  }

  // Hands pass between the camera and the objects, one hand at a time: each reach hovers in front
  // of one object, sweeps to another and withdraws. Hover heights clear the tallest object by
  // 9-14 cm (the fingers hang 9 cm below the palm centre).
  if (o.occlusion > 0.0f) {
    float tallest = 0.0f;
    for (const Placed& p : objects) tallest = std::max(tallest, 2.0f * p.half_height);
    const Eigen::Vector3f camera = make_world().world_to_camera.inverse().translation();
    const std::array<Iso, 2> homes{at(-0.75f, 0.10f, 0.35f), at(0.75f, 0.10f, 0.35f, kPi)};
    const std::array<int, 2> hands{b.add_body(make_hand(101), homes[0]), b.add_body(make_hand(102), homes[1])};
    const double idle_ratio = (1.0 - o.occlusion) / o.occlusion;
    const Eigen::Vector3f zero = Eigen::Vector3f::Zero();
    auto frames = [](double s) { return std::ceil(s * kFps - 1e-6) / kFps; };
    // The hand pose at hover height on the line of sight to a random object at time t.
    auto in_front_of_an_object = [&](int k, float hover, double t) {
      const Placed& target = objects[draw.index(static_cast<int>(objects.size()))];
      Eigen::Vector3f centre = b.scripted_pose(target.body, t).translation();
      centre.x() += draw.f(-0.04, 0.04);
      const float s = (camera.z() - hover) / (camera.z() - centre.z());
      const Eigen::Vector3f p = camera + s * (centre - camera);
      return at(p.x(), p.y(), hover, k == 0 ? 0.0f : kPi);
    };
    double th = draw(0.0, 2.0) * (1.0 - o.occlusion);
    while (th < duration) {
      const int k = draw.index(2);
      const float hover = tallest + draw.f(0.09, 0.14);
      const Iso p1 = in_front_of_an_object(k, hover, th + 2.5);
      const double d1 = frames(std::max(0.5, min_move_duration(homes[k], p1, zero)));
      const Iso p2 = in_front_of_an_object(k, hover, th + d1 + 1.0);
      const double d2 = frames(std::max(0.5, min_move_duration(p1, p2, zero)));
      const double d3 = frames(std::max(0.5, min_move_duration(p2, homes[k], zero)));
      b.key(hands[k], th, homes[k]);
      b.key(hands[k], th + d1, p1);
      b.key(hands[k], th + d1 + d2, p2);
      b.key(hands[k], th + d1 + d2 + d3, homes[k]);
      const double reach = d1 + d2 + d3;
      th += reach + reach * idle_ratio * draw(0.5, 1.5) + 0.2;
    }
  }
  return b.finish(duration);
}

// ---- hands-free rotation scenarios (issue 17) ----------------------------------------------
// Objects move by keyframes alone, sliding on the table or floating above it as on an invisible
// holder. The scenario seed picks the scene (turn directions, amounts and rates within each
// scenario's range, start yaws, paths); each scenario salts it so their draws differ.

Draw scene_draw(const ScenarioOptions& o, std::uint64_t salt) { return Draw(o.seed * kGolden + salt); }

float random_sign(Draw& draw) { return draw(0.0, 1.0) < 0.5 ? -1.0f : 1.0f; }

double at_frame(int frame) { return frame / kFps; }

constexpr float kDeg = kPi / 180.0f;

// A box slides on a straight line while turning about its vertical axis at steady rates of about
// 45, 90 and 180 deg/s (ramping between them at constant acceleration, from and back to rest),
// behind it a box and a can stand still.
Script spin_scenario(const ScenarioOptions& o) {
  Draw draw = scene_draw(o, 0x5b1eULL);
  ScriptBuilder b;
  const Eigen::Vector3f size(0.10f, 0.07f, 0.12f);
  const BodyInfo spinner_info = make_box(1, size, {kRed, kGreen, kBlue, kYellow, kMagenta, kCyan});
  // The slide: 16-28 cm across the front, within 15 degrees of the x axis, either way.
  const float heading = draw.f(-15.0, 15.0) * kDeg + (draw(0.0, 1.0) < 0.5 ? kPi : 0.0f);
  const float length = draw.f(0.16, 0.28);
  const Eigen::Vector2f centre(draw.f(-0.05, 0.05), draw.f(-0.04, 0.02));
  const Eigen::Vector2f from = centre - 0.5f * length * Eigen::Vector2f(std::cos(heading), std::sin(heading));
  const Eigen::Vector2f to = 2.0f * centre - from;
  const float start_yaw = draw.f(-kPi, kPi);
  const float direction = random_sign(draw);
  const double slow = draw(0.96, 1.0) * 45.0 * kDeg;  // rad/s; then twice and four times that
  const int steady_slow = 57 + draw.index(16), steady_medium = 57 + draw.index(16), steady_fast = 45 + draw.index(16);

  const int spinner = b.add_body(spinner_info, at(from.x(), from.y(), 0.5f * size.z(), start_yaw));
  const float side = random_sign(draw);
  b.add_body(make_box(2, {0.08f, 0.06f, 0.10f}, {kOrange, kPurple, kLime, kPink, kWhite, kBlack}, Pattern::checker,
                      kWhite, 0.04f),
             at(side * draw.f(0.10, 0.24), draw.f(0.24, 0.32), 0.05f, draw.f(-kPi, kPi)));
  b.add_body(make_can(3, 0.066f, 0.12f, kBlue, kWhite, kGrey),
             at(-side * draw.f(0.10, 0.24), draw.f(0.24, 0.32), 0.06f));

  // The turn as segments (frames, angle, profile); linear ones at most 60 degrees each, so every
  // slerp goes the intended way, and ramps between rates one frame per segment.
  struct Segment {
    int frames;
    double angle;
    Profile profile;
  };
  std::vector<Segment> turn;
  auto steady = [&](int frames, double rate) {
    const int per_segment = std::max(1, static_cast<int>(60.0 * kDeg / (rate / kFps)));
    for (int done = 0; done < frames; done += per_segment) {
      const int n = std::min(per_segment, frames - done);
      turn.push_back({n, rate * n / kFps, Profile::linear});
    }
  };
  auto ramp = [&](int frames, double rate0, double rate1) {
    for (int k = 0; k < frames; ++k) steady(1, rate0 + (rate1 - rate0) * (k + 0.5) / frames);
  };
  constexpr int kRampFrames = 15, kFastRampFrames = 24, kStopFrames = 30;
  turn.push_back({kRampFrames, 0.5 * slow * kRampFrames / kFps, Profile::ease_in});
  steady(steady_slow, slow);
  ramp(kRampFrames, slow, 2.0 * slow);
  steady(steady_medium, 2.0 * slow);
  ramp(kFastRampFrames, 2.0 * slow, 4.0 * slow);
  steady(steady_fast, 4.0 * slow);
  turn.push_back({kStopFrames, 0.5 * 4.0 * slow * kStopFrames / kFps, Profile::ease_out});

  // The slide advances with the turn: the box's centre is on the line at the share of the turn done.
  double total = 0.0;
  for (const Segment& s : turn) total += s.angle;
  auto pose_after = [&](double angle) {
    const Eigen::Vector2f p = from + static_cast<float>(angle / total) * (to - from);
    return at(p.x(), p.y(), 0.5f * size.z(), start_yaw + direction * static_cast<float>(angle));
  };
  int frame = 24;
  b.key(spinner, at_frame(frame), pose_after(0.0));
  double angle = 0.0;
  for (const Segment& s : turn) {
    frame += s.frames;
    angle += s.angle;
    b.key(spinner, at_frame(frame), pose_after(angle), s.profile);
  }
  b.wait(at_frame(frame));  // keys leave the timeline where it was
  return b.finish(1.2);
}

// A box rises 8-12 cm off the table (its lowest point stays 6 cm or more above it), tumbles 2.25-2.75 turns about one
// of its horizontal edges' directions while rocking +-1.1-1.2 rad about the other and drifting sideways, and settles on
// the table again (a whole number of quarter turns: it lands on a face). A can stands behind.
Script tumble_scenario(const ScenarioOptions& o) {
  Draw draw = scene_draw(o, 0x7a3b1eULL);
  ScriptBuilder b;
  const Eigen::Vector3f size(0.09f, 0.06f, 0.12f);
  const BodyInfo info = make_box(1, size, {kRed, kGreen, kBlue, kYellow, kMagenta, kCyan});
  const Eigen::Vector2f start(draw.f(-0.16, 0.16), draw.f(-0.02, 0.06));
  const float start_yaw = draw.f(-kPi, kPi);
  const float lift = draw.f(0.08, 0.12);
  const float drift = (start.x() > 0.0f ? -1.0f : 1.0f) * draw.f(0.08, 0.14);  // towards the middle: stays in view
  const int quarter_turns = 9 + draw.index(3);
  const float tumble = random_sign(draw) * quarter_turns * 0.5f * kPi;
  const float rock = random_sign(draw) * draw.f(1.1, 1.2);  // one cycle: +rock, -rock, back to 0

  const Iso rest = at(start.x(), start.y(), 0.5f * size.z(), start_yaw);
  const int box = b.add_body(info, rest);
  b.add_body(make_can(2, 0.066f, 0.12f, kOrange, kBlack, kGrey), at(draw.f(-0.20, 0.20), draw.f(0.28, 0.34), 0.06f));

  b.wait(0.5);
  const Iso lifted = raised(rest, lift);
  b.move({{box, lifted}}, 1.0);
  // Eased over the whole tumble (at rest at both ends); its length keeps the peak angular speed,
  // 1.5 times the mean of tumble and rock together, at 175 deg/s.
  const Eigen::Vector3f tumble_axis = rest.linear() * Eigen::Vector3f::UnitX();
  const Eigen::Vector3f rock_axis = rest.linear() * Eigen::Vector3f::UnitY();
  const double peak = 1.5 * std::hypot(tumble, 2.0 * kPi * rock);
  const int frames = static_cast<int>(std::ceil(peak / (175.0 * kDeg) * kFps));
  const double start_s = b.now();
  // Tumble and rock compose into no single slerp: keyed at every frame.
  for (int k = 1; k <= frames; ++k) {
    const double tau = static_cast<double>(k) / frames;
    const auto s = static_cast<float>(progress(Profile::eased, tau));
    Iso pose = lifted;
    pose.linear() = Eigen::AngleAxisf(s * tumble, tumble_axis).toRotationMatrix() *
                    Eigen::AngleAxisf(rock * std::sin(2.0f * kPi * s), rock_axis).toRotationMatrix() * rest.linear();
    pose.translation().x() += s * drift;
    b.key(box, start_s + at_frame(k), pose, Profile::linear);
  }
  b.wait(at_frame(frames));
  // Lying on the face that the quarter turns put down.
  Iso landed = b.pose(box);
  landed.translation().z() = 0.5f * (landed.linear().row(2).cwiseAbs() * size).value();
  b.move({{box, landed}}, 1.0);
  return b.finish(0.5);
}

// A box slides across the table turning 0.6-0.8 rad and is pushed against a side face of another
// box (faces touching to 0.5 mm), stays there, then slides away turning back.
Script slide_scenario(const ScenarioOptions& o) {
  Draw draw = scene_draw(o, 0x511deULL);
  ScriptBuilder b;
  const float gap = 0.0005f;
  const Eigen::Vector3f mover_size(0.08f, 0.07f, 0.11f), anchor_size(0.10f, 0.08f, 0.10f);
  const float side = random_sign(draw);  // the anchor face touched: its -x or +x face
  const float anchor_yaw = draw.f(-0.3, 0.3);
  const Iso anchor = at(-side * draw.f(0.04, 0.10), draw.f(0.08, 0.18), 0.5f * anchor_size.z(), anchor_yaw);
  // Touching: the mover's x faces parallel to the anchor's, offset along the face by up to 1.5 cm.
  const Iso contact = anchor * at(side * (0.5f * (anchor_size.x() + mover_size.x()) + gap), draw.f(-0.015, 0.015),
                                  0.5f * (mover_size.z() - anchor_size.z()));
  // Where it comes from and goes to: 16-22 cm (12-20 cm) out from the face within 0.4 (0.6) rad
  // of its normal. Its corner cannot reach the face before it: the distance to go along the
  // normal stays larger than the half width times the angle still to turn.
  auto away = [&](float distance, float angle, float yaw_offset) {
    const Eigen::Vector3f step = anchor.linear() * Eigen::Vector3f(side * std::cos(angle), std::sin(angle), 0.0f);
    Iso pose = contact;
    pose.translation() += distance * step;
    pose.linear() = Eigen::AngleAxisf(yaw_offset, Eigen::Vector3f::UnitZ()).toRotationMatrix() * contact.linear();
    return pose;
  };
  const float turn = random_sign(draw) * draw.f(0.6, 0.8);
  const Iso start = away(draw.f(0.16, 0.22), draw.f(-0.4, 0.4), -turn);
  const Iso end = away(draw.f(0.12, 0.20), draw.f(-0.6, 0.6), -turn * draw.f(0.6, 1.0));

  const int mover = b.add_body(make_box(1, mover_size, {kRed, kGreen, kBlue, kYellow, kMagenta, kCyan}), start);
  b.add_body(
      make_box(2, anchor_size, {kOrange, kPurple, kLime, kPink, kWhite, kBlack}, Pattern::checker, kWhite, 0.04f),
      anchor);

  b.wait(1.5);
  b.move({{mover, contact}}, draw(2.5, 3.0));
  b.wait(draw(2.0, 2.5));
  b.move({{mover, end}}, draw(2.5, 3.0));
  return b.finish(1.5);
}

// A tall box slides across the front turning 0.7-0.9 rad, passing between the camera and another
// box (hiding much of it), and back again turning 0.5-0.9 rad.
Script cross_scenario(const ScenarioOptions& o) {
  Draw draw = scene_draw(o, 0xc4055ULL);
  ScriptBuilder b;
  const Eigen::Vector3f mover_size(0.10f, 0.07f, 0.16f), hidden_size(0.09f, 0.07f, 0.10f);
  const float from_x = random_sign(draw) * 0.27f;
  const float start_yaw = draw.f(-kPi, kPi);
  const float turn = random_sign(draw) * draw.f(0.7, 0.9);
  const float z = 0.5f * mover_size.z();
  const Iso start = at(from_x, draw.f(0.04, 0.10), z, start_yaw);
  const Iso across = at(-from_x, draw.f(0.04, 0.10), z, start_yaw + turn);
  const Iso back = at(from_x * draw.f(0.7, 1.0), draw.f(0.04, 0.10), z, start_yaw + turn - turn * draw.f(0.6, 1.0));

  const int mover = b.add_body(make_box(1, mover_size, {kRed, kGreen, kBlue, kYellow, kMagenta, kCyan}), start);
  b.add_body(
      make_box(2, hidden_size, {kOrange, kPurple, kLime, kPink, kWhite, kBlack}, Pattern::stripes, kWhite, 0.04f),
      at(draw.f(-0.08, 0.08), draw.f(0.26, 0.32), 0.5f * hidden_size.z(), draw.f(-0.5, 0.5)));

  b.wait(1.0);
  b.move({{mover, across}}, draw(4.0, 5.0));
  b.wait(1.0);
  b.move({{mover, back}}, draw(4.0, 5.0));
  return b.finish(0.5);
}

}  // namespace

World make_world(float pitch, float distance, const Eigen::Vector3f& target) {
  World world;
  // Camera `distance` from the look-at point on the table, `pitch` down; x right, y down, z forward.
  const Eigen::Vector3f position = target + distance * Eigen::Vector3f(0.0f, -std::cos(pitch), std::sin(pitch));
  const Eigen::Vector3f z = (target - position).normalized(), x = Eigen::Vector3f::UnitX(), y = z.cross(x);
  Eigen::Matrix3f camera_to_world;
  camera_to_world << x, y, z;
  world.world_to_camera.linear() = camera_to_world.transpose();
  world.world_to_camera.translation() = -(camera_to_world.transpose() * position);

  Plane table;
  table.pose.translation = Eigen::Vector3f(0.0f, 0.05f, 0.0f);
  table.half_extent_x = 0.70f;
  table.half_extent_y = 0.55f;
  table.color_a = {186, 142, 98};
  table.color_b = {166, 122, 80};
  table.tile_m = 0.10f;
  world.planes.push_back(table);

  Plane floor;
  floor.pose.translation = Eigen::Vector3f(0.0f, 0.0f, -0.72f);
  floor.color_a = {120, 120, 128};
  floor.color_b = {100, 100, 108};
  floor.tile_m = 0.30f;
  world.planes.push_back(floor);

  Plane wall;  // facing the camera
  wall.pose.translation = Eigen::Vector3f(0.0f, 1.8f, 0.0f);
  wall.pose.rotation = Eigen::Quaternionf(Eigen::AngleAxisf(kPi / 2.0f, Eigen::Vector3f::UnitX()));
  wall.color_a = wall.color_b = {214, 208, 192};
  world.planes.push_back(wall);

  world.light_direction = Eigen::Vector3f(0.25f, -0.35f, 1.0f).normalized();
  return world;
}

// Objects that start stacked and touching (one cluster each pair at frame 0: only discovery by
// convexity finds them apart) and are separated later by a hand: the top box is lifted off the
// one below and put down elsewhere, then a box is taken away from the taller one it touches.
Script apart_scenario() {
  ScriptBuilder b;
  Bodies s;
  const float gap = 0.0005f;
  const Eigen::Vector3f base_size(0.16f, 0.12f, 0.07f), top_size(0.07f, 0.06f, 0.09f);
  s.add(b, make_box(2, base_size, {kOrange, kPurple, kLime, kPink, kWhite, kBlack}, Pattern::stripes, kWhite, 0.04f),
        at(0.12f, 0.06f, 0.5f * base_size.z()));
  const int top = s.add(b, make_box(1, top_size, {kRed, kGreen, kBlue, kYellow, kMagenta, kCyan}),
                        at(0.12f, 0.06f, base_size.z() + gap + 0.5f * top_size.z()));
  const Eigen::Vector3f tall_size(0.08f, 0.08f, 0.11f), low_size(0.08f, 0.07f, 0.06f);
  s.add(b, make_box(3, tall_size, {kBlue, kYellow, kRed, kGreen, kWhite, kBlack}, Pattern::checker, kWhite, 0.04f),
        at(-0.12f, 0.12f, 0.5f * tall_size.z()));
  // Touching the tall box's left face (the hand's side: its arm never crosses the tall box), set back
  // 5 mm so the front faces are not flush.
  const int low = s.add(b, make_box(4, low_size, {kCyan, kOrange, kMagenta, kLime, kPurple, kPink}),
                        at(-0.12f - 0.5f * tall_size.x() - gap - 0.5f * low_size.x(), 0.125f, 0.5f * low_size.z()));
  const Iso home = at(-0.75f, 0.05f, 0.35f);
  const int hand = s.add(b, make_hand(101), home);

  b.wait(1.5);
  pick_and_place(b, s.infos, hand, top, 0.0f, at(0.02f, -0.10f, 0.5f * top_size.z(), -15.0f * kPi / 180.0f), 0.06f);
  b.move({{hand, home}});
  b.wait(1.0);
  // Fingers over its back face: its right face touches the tall box.
  pick_and_place(b, s.infos, hand, low, 0.5f * kPi, at(-0.30f, 0.30f, 0.5f * low_size.z(), 25.0f * kPi / 180.0f),
                 0.06f);
  b.move({{hand, home}});
  return b.finish(0.8);
}

Script build_scenario(const ScenarioOptions& options, int attempt) {
  if (options.name == "apart") return apart_scenario();
  if (options.name == "stack") return stack_scenario();
  if (options.name == "contact") return contact_scenario();
  if (options.name == "rotate") return rotate_scenario();
  if (options.name == "static") return static_scenario();
  if (options.name == "random") return random_scenario(options, attempt);
  if (options.name == "spin") return spin_scenario(options);
  if (options.name == "tumble") return tumble_scenario(options);
  if (options.name == "slide") return slide_scenario(options);
  if (options.name == "cross") return cross_scenario(options);
  if (options.name == "procedural") return procedural_scenario(options, attempt);
  throw std::invalid_argument(
      "ScenarioOptions.name must be one of stack, contact, rotate, apart, static, random, spin, tumble, slide, cross, "
      "procedural");
}

}  // namespace mfot::sim::detail
