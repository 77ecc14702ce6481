// The procedural scenario: a seeded generator of whole table-top scenes, so that the tracker is
// measured on a distribution of scenes rather than on a few scripted ones (issue 53).
//
// Steps of procedural_scenario; every draw comes from one generator seeded by the scenario seed
// (and the layout attempt), so a seed always gives the same scene:
//  1. Camera: 0.8-1.1 m from a look-at point near the table centre, 35-65 degrees below the
//     horizontal (camera height 0.46-1.0 m above the table top).
//  2. Motion class (slide, push, spin, tilt, stack, tumble) and mover (hand, gripper or nothing
//     visible; spin and tumble turn whole turns, which a hand cannot: gripper or nothing).
//  3. Object count, 1-20, skewed towards few (1 + floor(20 u^2), u uniform; at least the motion's
//     own objects). Shapes box, can, bottle (body, neck, cap), mug (body, handle); textures plain,
//     stripes, printed label, checker.
//  4. Layout: the moved objects (push: a chain of 2-3 on one line; stack: the moved one and its
//     base) first, then the others at random places whose footprint circles keep 4 cm from every
//     other footprint and from the footprint swept by the motion (a crowded table gets smaller
//     objects; one that finds no place even at half size is left out).
//  5. Motion programme, keyed at every frame: slide (1-2 legs on the table, turning up to 0.9 rad
//     each), push (the first of the chain slides into the next, which then moves in contact, and so
//     on; contacts exact to 0.5 mm), spin (1-2 turns standing on the table about its vertical axis,
//     or lifted, whole turns about a random body axis or the symmetry axis), tilt (lifted, tilted
//     75-120 degrees about a horizontal axis, held, tilted back, set down), stack (lifted over the
//     tallest object, carried onto the top of a box or can, 0.5 mm above it), tumble (lifted,
//     2-2.75 turns about a horizontal body axis while rocking, lands on a face). Peak speeds stay
//     under 0.27 m/s and 180 deg/s; every object stays on or above the table.
//  6. Mover: a hand (slide, push, stack: grasping from above, objects 9 cm tall or more) or a
//     parallel gripper (its wrist rod along the turn axis for spin and tumble, so whole turns are
//     wrist turns; from the side for tilt, so the rod stays above the horizontal; from above
//     otherwise) holds the object rigidly for the programme. It waits out of the image at the
//     nearer table side, comes in high over every object and down onto the grasp, and leaves the
//     same way; the table under it while it holds is kept free of other objects.
//  7. Summary: motion class, mover, objects' shapes and textures, spin axis and camera (scene.yaml).
// A can or bottle carries its symmetry axis (BodyInfo, the ground truth's axis columns) only when plain: a
// texture that varies around it (stripes, label, checker) makes its turn about the axis observable.

#include <algorithm>
#include <cmath>
#include <functional>

#include "script.hpp"

namespace mfot::sim::detail {

namespace {

constexpr float kPi = 3.14159265f;
constexpr float kDeg = kPi / 180.0f;
constexpr float kGap = 0.0005f;      // touching contacts, metres
constexpr float kClearance = 0.04f;  // least gap between footprint circles at frame 0, metres
constexpr float kXMin = -0.34f, kXMax = 0.34f, kYMin = -0.16f, kYMax = 0.40f;  // table area used, world
constexpr double kPeakTurn = 170.0 * 3.14159265 / 180.0;  // rad/s, peak of the fast turns (spin, tumble)
constexpr int kMaxObjects = 20;
constexpr int kMoverId = 101;

enum class Shape { box, can, bottle, mug };
enum class Texture { plain, stripes, label, checker };
enum class Motion { slide, push, spin, tilt, stack, tumble };
enum class Mover { none, hand, gripper };
constexpr std::array<const char*, 4> kShapeNames{"box", "can", "bottle", "mug"};
constexpr std::array<const char*, 4> kTextureNames{"plain", "stripes", "label", "checker"};
constexpr std::array<const char*, 6> kMotionNames{"slide", "push", "spin", "tilt", "stack", "tumble"};
constexpr std::array<const char*, 3> kMoverNames{"none", "hand", "gripper"};

Iso at(float x, float y, float z, float yaw = 0.0f) {
  Iso t = Iso::Identity();
  t.linear() = Eigen::AngleAxisf(yaw, Eigen::Vector3f::UnitZ()).toRotationMatrix();
  t.translation() = Eigen::Vector3f(x, y, z);
  return t;
}

double frames_of(double seconds) { return std::ceil(seconds * kFps - 1e-6) / kFps; }

double eased(double t, double duration) {
  return progress(Profile::eased, std::clamp(duration > 0.0 ? t / duration : 1.0, 0.0, 1.0));
}

// A shape of the given class with random size and colours; body origin at the centre of its
// bounding box, z along its axis, standing on its bottom face. scale in (0, 1] shrinks it.
BodyInfo make_shape(Draw& draw, int id, Shape shape, Texture texture, float scale) {
  std::array<Rgb8, kPalette.size()> colours = kPalette;
  for (int i = static_cast<int>(colours.size()) - 1; i > 0; --i) std::swap(colours[i], colours[draw.index(i + 1)]);
  Primitive main;
  main.label = static_cast<std::uint16_t>(id);
  main.pattern = texture == Texture::plain     ? Pattern::solid
                 : texture == Texture::stripes ? Pattern::stripes
                 : texture == Texture::label   ? Pattern::label
                                               : Pattern::checker;
  main.pattern_color = colours[6];
  main.print_color = colours[7];
  main.pattern_period_m = draw.f(0.02, 0.05);
  auto size = [&](double lo, double hi) { return std::max(0.04f, draw.f(lo, hi) * scale); };
  BodyInfo info{id, false, {}};
  if (shape == Shape::box) {
    main.kind = PrimitiveKind::box;
    main.size = Eigen::Vector3f(size(0.05, 0.14), size(0.05, 0.14), size(0.05, 0.18));
    main.face_colors = {colours[0], colours[1], colours[2], colours[3], colours[4], colours[5]};
    info.primitives.push_back(main);
    return info;
  }
  main.kind = PrimitiveKind::cylinder;
  main.face_colors = {colours[0], colours[0], colours[0], colours[0], colours[1], colours[1]};
  info.symmetry_axis = Eigen::Vector3f::UnitZ();
  if (shape == Shape::can) {
    const float d = size(0.055, 0.10);
    main.size = Eigen::Vector3f(d, d, size(0.08, 0.18));
    info.primitives.push_back(main);
    return info;
  }
  if (shape == Shape::bottle) {
    const float d = size(0.055, 0.09), body = size(0.10, 0.18);
    const float neck_d = std::max(0.02f, d * draw.f(0.3, 0.45)), neck = size(0.04, 0.08);
    const float total = body + neck;
    main.size = Eigen::Vector3f(d, d, body);
    main.pose.translation = Eigen::Vector3f(0.0f, 0.0f, 0.5f * (body - total));
    info.primitives.push_back(main);
    Primitive neck_part = main;
    neck_part.pattern = Pattern::solid;
    neck_part.size = Eigen::Vector3f(neck_d, neck_d, neck);
    neck_part.pose.translation = Eigen::Vector3f(0.0f, 0.0f, 0.5f * (total - neck));
    neck_part.face_colors = {colours[2], colours[2], colours[2], colours[2], colours[2], colours[2]};
    info.primitives.push_back(neck_part);
    Primitive cap = neck_part;
    const float cap_height = std::min(0.018f, 0.5f * neck);
    cap.size = Eigen::Vector3f(neck_d + 0.006f, neck_d + 0.006f, cap_height);
    cap.pose.translation = Eigen::Vector3f(0.0f, 0.0f, 0.5f * (total - cap_height));
    cap.face_colors = {colours[3], colours[3], colours[3], colours[3], colours[3], colours[3]};
    info.primitives.push_back(cap);
    return info;
  }
  // Mug: body and a handle on its +x side (no symmetry axis).
  const float d = size(0.07, 0.10), h = size(0.08, 0.11);
  main.size = Eigen::Vector3f(d, d, h);
  info.primitives.push_back(main);
  Primitive handle;
  handle.kind = PrimitiveKind::box;
  handle.label = main.label;
  handle.size = Eigen::Vector3f(0.024f, 0.012f, 0.55f * h);
  handle.pose.translation = Eigen::Vector3f(0.5f * d + 0.009f, 0.0f, 0.0f);
  handle.face_colors.fill(colours[2]);
  info.primitives.push_back(handle);
  info.symmetry_axis = Eigen::Vector3f::Zero();
  return info;
}

// A parallel gripper (gripper frame: origin at the middle of the palm's underside, z along the
// wrist rod, away from the object; the fingers at +-x reach down to z = -finger_length and their
// inner faces are grip_half_width + 1 mm from the axis).
BodyInfo make_gripper(int id, float grip_half_width, float finger_length) {
  const Rgb8 metal{150, 152, 160}, dark{55, 58, 66}, rod_colour{185, 185, 192};
  const auto label = static_cast<std::uint16_t>(id);
  BodyInfo gripper{id, true, {}};
  Primitive palm;
  palm.kind = PrimitiveKind::box;
  palm.size = Eigen::Vector3f(2.0f * grip_half_width + 0.04f, 0.035f, 0.02f);
  palm.pose.translation = Eigen::Vector3f(0.0f, 0.0f, 0.01f);
  palm.face_colors.fill(metal);
  palm.label = label;
  gripper.primitives.push_back(palm);
  for (const float side : {-1.0f, 1.0f}) {
    Primitive finger = palm;
    finger.size = Eigen::Vector3f(0.012f, 0.028f, finger_length + 0.02f);
    finger.pose.translation = Eigen::Vector3f(side * (grip_half_width + 0.007f), 0.0f, 0.5f * (0.02f - finger_length));
    finger.face_colors.fill(dark);
    gripper.primitives.push_back(finger);
  }
  Primitive rod;
  rod.kind = PrimitiveKind::cylinder;
  rod.size = Eigen::Vector3f(0.045f, 0.045f, 0.40f);
  rod.pose.translation = Eigen::Vector3f(0.0f, 0.0f, 0.22f);
  rod.face_colors.fill(rod_colour);
  rod.label = label;
  gripper.primitives.push_back(rod);
  return gripper;
}

// The gripper frame in the body frame of an object with half extents `half` grasped along body
// axis `axis` (unit): on the plane that touches the bounding box on the +axis side, fingers across
// the perpendicular direction `across`. Sets the grip half width and finger length to use.
Iso gripper_offset(const Eigen::Vector3f& half, const Eigen::Vector3f& axis, float& grip_half, float& finger) {
  const Eigen::Vector3f helper = std::abs(axis.x()) < 0.9f ? Eigen::Vector3f::UnitX() : Eigen::Vector3f::UnitY();
  const Eigen::Vector3f across = (helper - helper.dot(axis) * axis).normalized();
  const float support = axis.cwiseAbs().dot(half);
  grip_half = across.cwiseAbs().dot(half);
  finger = std::min(0.05f, support);
  Iso g = Iso::Identity();
  g.linear().col(0) = across;
  g.linear().col(1) = axis.cross(across);
  g.linear().col(2) = axis;
  g.translation() = support * axis;
  return g;
}

Eigen::Vector3f random_unit(Draw& draw) {
  const float z = draw.f(-1.0, 1.0), phi = draw.f(-kPi, kPi);
  const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
  return {r * std::cos(phi), r * std::sin(phi), z};
}

// Lowest point (world z) of a body with half extents half at pose.
float lowest(const Iso& pose, const Eigen::Vector3f& half) {
  return pose.translation().z() - pose.linear().row(2).cwiseAbs().dot(half);
}

struct Circle {
  Eigen::Vector2f xy;
  float r;
};

bool in_area(const Eigen::Vector2f& xy, float r) {
  return xy.x() >= kXMin + r && xy.x() <= kXMax - r && xy.y() >= kYMin + r && xy.y() <= kYMax - r;
}

bool clear_of(const std::vector<Circle>& taken, const Eigen::Vector2f& xy, float r) {
  return std::all_of(taken.begin(), taken.end(),
                     [&](const Circle& c) { return (c.xy - xy).norm() >= c.r + r + kClearance; });
}

// A moved object's programme: its world pose at programme time t in [0, duration].
struct Member {
  int body = -1;
  std::function<Iso(double)> pose;
};

// The generator of one procedural scene (steps 4-7 of the file comment): owns the seeded draws,
// the script being built and the summary; each motion method lays out the moved objects of its
// class and sets their programme (members, duration).
struct Generator {
  Draw draw;
  ScriptBuilder builder;
  SceneSummary summary;
  std::vector<Circle> taken;  // footprints at frame 0 and swept by the motion
  std::vector<Member> members;
  double duration = 0.0;  // of the programme, seconds
  Mover mover = Mover::none;
  float push_heading = 0.0f;  // push: direction of the chain's line (world yaw)

  explicit Generator(std::uint64_t seed) : draw(seed) {}

  Shape any_shape() { return static_cast<Shape>(draw.index(4)); }
  Texture any_texture() { return static_cast<Texture>(draw.index(4)); }

  // The body keeps its symmetry axis only when plain: stripes, a label or a checker on a can show its turns
  // about the axis, so the ground truth (and the evaluator) asks for its full rotation.
  int add_object(const BodyInfo& info, Shape shape, Texture texture, const Iso& pose, bool moved) {
    summary.objects.push_back(
        {info.id, kShapeNames[static_cast<int>(shape)], kTextureNames[static_cast<int>(texture)], moved});
    BodyInfo body = info;
    if (texture != Texture::plain) body.symmetry_axis = Eigen::Vector3f::Zero();
    return builder.add_body(body, pose);
  }

  // Sweeps circles of radius r along the straight path a -> b (every centimetre) into taken.
  void sweep(const Eigen::Vector2f& a, const Eigen::Vector2f& b, float r) {
    const int steps = 1 + static_cast<int>((b - a).norm() / 0.01f);
    for (int k = 0; k <= steps; ++k) taken.push_back({a + (b - a) * (static_cast<float>(k) / steps), r});
  }

  // A random upright pose for an object of footprint radius r inside the area, clear of taken.
  bool free_spot(float r, Eigen::Vector2f& xy) {
    for (int tries = 0; tries < 200; ++tries) {
      xy = Eigen::Vector2f(draw.f(kXMin + r, kXMax - r), draw.f(kYMin + r, kYMax - r));
      if (clear_of(taken, xy, r)) return true;
    }
    return false;
  }

  // ---- motion layouts: add the moved objects and their programmes -----------------------------
  void slide(const BodyInfo& info, Shape shape, Texture texture) {
    const float r = footprint_radius(info), hh = half_height(info);
    Eigen::Vector2f xy;
    float yaw = draw.f(-kPi, kPi);
    free_spot(r, xy);
    struct Leg {
      Eigen::Vector2f from, to;
      float yaw_from, yaw_to;
      double t0, length;
    };
    std::vector<Leg> legs;
    const int count = 1 + draw.index(2);
    double t = 0.0;
    Eigen::Vector2f at_xy = xy;
    for (int k = 0; k < count; ++k) {
      for (int tries = 0; tries < 30; ++tries) {
        const float heading = draw.f(-kPi, kPi), length = draw.f(0.10, 0.22), turn = draw.f(-0.9, 0.9);
        const Eigen::Vector2f to = at_xy + length * Eigen::Vector2f(std::cos(heading), std::sin(heading));
        if (!in_area(to, r)) continue;
        const double time = frames_of(
            std::max({draw(1.5, 2.5), 1.5 * length / kMaxLinearSpeed, 1.5 * std::abs(turn) / kMaxAngularSpeed}));
        legs.push_back({at_xy, to, yaw, yaw + turn, t, time});
        sweep(at_xy, to, r);
        at_xy = to;
        yaw += turn;
        t += time + frames_of(draw(0.3, 0.8));
        break;
      }
    }
    taken.push_back({xy, r});
    duration = legs.empty() ? 1.0 : legs.back().t0 + legs.back().length;
    const float yaw0 = legs.empty() ? yaw : legs.front().yaw_from;
    const int body = add_object(info, shape, texture, at(xy.x(), xy.y(), hh, yaw0), true);
    members.push_back({body, [legs, xy, yaw0, hh](double time) {
                         Eigen::Vector2f p = xy;
                         float yaw_now = yaw0;
                         for (const Leg& leg : legs) {
                           if (time < leg.t0) break;
                           const auto s = static_cast<float>(eased(time - leg.t0, leg.length));
                           p = leg.from + s * (leg.to - leg.from);
                           yaw_now = leg.yaw_from + s * (leg.yaw_to - leg.yaw_from);
                         }
                         return at(p.x(), p.y(), hh, yaw_now);
                       }});
  }

  // A chain on one line along heading: the first slides into the second, which moves on in
  // contact into the third; contacts exact to kGap.
  void push(int count, std::vector<BodyInfo>& infos, const std::vector<Shape>& shapes,
            const std::vector<Texture>& textures) {
    std::vector<float> extent(count), yaw(count), gap(count, 0.0f);
    for (int tries = 0;; ++tries) {
      const float heading = draw.f(-kPi, kPi);
      push_heading = heading;
      const Eigen::Vector2f dir(std::cos(heading), std::sin(heading));
      for (int k = 0; k < count; ++k) {
        const Primitive& p = infos[k].primitives.front();
        if (shapes[k] == Shape::box) {
          const int quarter = draw.index(4);
          yaw[k] = heading + quarter * 0.5f * kPi;
          extent[k] = 0.5f * (quarter % 2 == 0 ? p.size.x() : p.size.y());
        } else {
          // Round shapes touch with their body; a mug's handle points sideways.
          yaw[k] = shapes[k] == Shape::mug ? heading + random_sign() * 0.5f * kPi : draw.f(-kPi, kPi);
          extent[k] = 0.5f * p.size.x();
        }
        if (k > 0) gap[k] = draw.f(0.04, 0.08);
      }
      const float pushed = draw.f(0.05, 0.12);
      std::vector<float> start(count, 0.0f), contact(count, 0.0f);
      for (int k = 1; k < count; ++k) {
        contact[k] = contact[k - 1] + extent[k - 1] + extent[k] + kGap;
        start[k] = start[k - 1] + extent[k - 1] + extent[k] + kGap + gap[k];
      }
      float travel = pushed;
      for (int k = 1; k < count; ++k) travel += gap[k];
      const Eigen::Vector2f origin(draw.f(kXMin, kXMax), draw.f(kYMin, kYMax));
      bool inside = true;
      for (int k = 0; k < count && inside; ++k) {
        const float r = footprint_radius(infos[k]);
        inside =
            in_area(origin + start[k] * dir, r) && in_area(origin + std::max(start[k], travel + contact[k]) * dir, r);
      }
      if (!inside && tries < 200) continue;
      if (!inside) {
        for (BodyInfo& info : infos) info = shrunk(info, 0.9f);
        tries = 0;
        continue;
      }
      for (int k = 0; k < count; ++k) {
        const float r = footprint_radius(infos[k]);
        sweep(origin + start[k] * dir, origin + std::max(start[k], travel + contact[k]) * dir, r);
      }
      duration = frames_of(std::max(draw(2.5, 4.0), 1.5 * travel / kMaxLinearSpeed));
      const double time = duration;
      for (int k = 0; k < count; ++k) {
        const float hh = half_height(infos[k]);
        const Eigen::Vector2f p0 = origin + start[k] * dir;
        const int body = add_object(infos[k], shapes[k], textures[k], at(p0.x(), p0.y(), hh, yaw[k]), true);
        const float begin = start[k], offset = contact[k], yk = yaw[k];
        members.push_back({body, [=](double t) {
                             const auto pusher = static_cast<float>(travel * eased(t, time));
                             const Eigen::Vector2f p = origin + std::max(begin, pusher + offset) * dir;
                             return at(p.x(), p.y(), hh, yk);
                           }});
      }
      return;
    }
  }

  // Lifted to a height where the lowest point of the turning body stays `clearance` above the table.
  static float lift_for(const Eigen::Vector3f& half, float hh, float clearance) {
    return std::max(0.0f, half.norm() - hh) + clearance;
  }

  void spin(const BodyInfo& info, Shape shape, Texture texture) {
    const Eigen::Vector3f half = half_extents(info);
    const float r = footprint_radius(info), hh = half_height(info);
    const bool on_table = draw(0.0, 1.0) < 0.6;
    const bool symmetric = !info.symmetry_axis.isZero();
    Eigen::Vector3f axis = Eigen::Vector3f::UnitZ();
    float angle = 0.0f;
    const float sign = random_sign();
    if (on_table) {
      angle = sign * draw.f(1.0, 2.0) * 2.0f * kPi;
    } else {
      if (!(symmetric && draw(0.0, 1.0) < 0.4)) axis = random_unit(draw);
      angle = sign * static_cast<float>(1 + draw.index(2)) * 2.0f * kPi;  // whole turns: it lands as it rose
    }
    const float reach = on_table ? r : half.norm();
    Eigen::Vector2f xy;
    free_spot(reach, xy);
    taken.push_back({xy, reach});
    const float yaw0 = draw.f(-kPi, kPi);
    const Iso rest = at(xy.x(), xy.y(), hh, yaw0);
    const double turn = frames_of(std::max(draw(3.0, 5.0), 1.5 * std::abs(angle) / kPeakTurn));
    const double rise = on_table ? 0.0 : frames_of(1.0);
    const float lift = on_table ? 0.0f : lift_for(half, hh, draw.f(0.05, 0.08));
    // The world axis of the turn stays the body's `axis`: R(t) axis = AngleAxis(a, w) R0 axis = w.
    const Eigen::Vector3f world_axis = rest.linear() * axis;
    duration = 2.0 * rise + turn;
    summary.spin_axis = axis;
    summary.spin_angle_rad = angle;
    summary.spin_on_table = on_table;
    const int body = add_object(info, shape, texture, rest, true);
    members.push_back({body, [=](double t) {
                         Iso pose = rest;
                         const double up = on_table ? 0.0 : eased(t, rise) - eased(t - rise - turn, rise);
                         pose.translation().z() += static_cast<float>(up) * lift;
                         const auto a = static_cast<float>(angle * eased(t - rise, turn));
                         pose.linear() = Eigen::AngleAxisf(a, world_axis).toRotationMatrix() * rest.linear();
                         return pose;
                       }});
    grasp_axis = axis;
  }

  void tilt(const BodyInfo& info, Shape shape, Texture texture) {
    const Eigen::Vector3f half = half_extents(info);
    const float hh = half_height(info), reach = half.norm();
    Eigen::Vector2f xy;
    free_spot(reach, xy);
    taken.push_back({xy, reach});
    const float yaw0 = draw.f(-kPi, kPi), heading = draw.f(-kPi, kPi);
    const float angle = draw.f(75.0, 120.0) * kDeg;
    const Eigen::Vector3f axis(std::cos(heading), std::sin(heading), 0.0f);
    const Iso rest = at(xy.x(), xy.y(), hh, yaw0);
    // Lowest point over the tilt at least 3-6 cm above the table.
    const float clearance = draw.f(0.03, 0.06);
    float lift = 0.04f;
    for (int k = 0; k <= 12; ++k) {
      Iso p = rest;
      p.linear() = Eigen::AngleAxisf(angle * k / 12.0f, axis).toRotationMatrix() * rest.linear();
      lift = std::max(lift, clearance - lowest(p, half));
    }
    const double rise = frames_of(std::max(0.8, 1.5 * lift / kMaxLinearSpeed));
    const double turn = frames_of(std::max(draw(1.2, 2.0), 1.5 * angle / kMaxAngularSpeed));
    const double hold = frames_of(draw(0.5, 1.0));
    duration = 2.0 * rise + 2.0 * turn + hold;
    // A gripper holds it from the side whose normal the tilt turns upwards: its rod stays above
    // the horizontal.
    grasp_axis = rest.linear().transpose() * Eigen::Vector3f::UnitZ().cross(axis);
    const int body = add_object(info, shape, texture, rest, true);
    members.push_back({body, [=](double t) {
                         Iso pose = rest;
                         const double up = eased(t, rise) - eased(t - rise - 2.0 * turn - hold, rise);
                         pose.translation().z() += static_cast<float>(up) * lift;
                         const double s = eased(t - rise, turn) - eased(t - rise - turn - hold, turn);
                         pose.linear() =
                             Eigen::AngleAxisf(static_cast<float>(s) * angle, axis).toRotationMatrix() * rest.linear();
                         return pose;
                       }});
  }

  // The moved object and its base (a box or can); the programme is made once every object is
  // placed (the carry clears the tallest one).
  struct StackPlan {
    int moved = -1, base = -1;
    Iso from, onto;
    float moved_hh = 0.0f;
  } stack_plan;

  void stack(const BodyInfo& info, Shape shape, Texture texture, const BodyInfo& base_info, Shape base_shape,
             Texture base_texture) {
    const float r = footprint_radius(info), rb = footprint_radius(base_info);
    Eigen::Vector2f a, b;
    for (int tries = 0; tries < 400; ++tries) {
      free_spot(r, a);
      const float heading = draw.f(-kPi, kPi), distance = draw.f(0.15, 0.30);
      b = a + distance * Eigen::Vector2f(std::cos(heading), std::sin(heading));
      if (in_area(b, rb) && (b - a).norm() >= r + rb + kClearance && clear_of(taken, b, rb)) break;
    }
    taken.push_back({a, r});
    taken.push_back({b, rb});
    const float yaw0 = draw.f(-kPi, kPi);
    stack_plan.from = at(a.x(), a.y(), half_height(info), yaw0);
    const float base_top = 2.0f * half_height(base_info);
    stack_plan.onto = at(b.x(), b.y(), base_top + kGap + half_height(info), yaw0 + draw.f(-0.6, 0.6));
    stack_plan.moved_hh = half_height(info);
    stack_plan.moved = add_object(info, shape, texture, stack_plan.from, true);
    stack_plan.base = add_object(base_info, base_shape, base_texture,
                                 at(b.x(), b.y(), half_height(base_info), draw.f(-kPi, kPi)), false);
    summary.stack_base_id = base_info.id;
  }

  void stack_programme(float tallest) {
    const StackPlan p = stack_plan;
    const float carry_z = tallest + 0.03f + p.moved_hh;
    Iso up = p.from, over = p.onto;
    up.translation().z() = over.translation().z() = std::max(carry_z, p.onto.translation().z() + 0.02f);
    const Eigen::Vector3f zero = Eigen::Vector3f::Zero();
    const double rise = frames_of(std::max(0.8, min_move_duration(p.from, up, zero)));
    const double carry = frames_of(std::max(draw(1.2, 2.0), min_move_duration(up, over, zero)));
    const double lower = frames_of(std::max(0.8, min_move_duration(over, p.onto, zero)));
    duration = rise + carry + lower;
    members.push_back({p.moved, [=](double t) {
                         if (t < rise) return interpolate(p.from, up, zero, t / rise);
                         if (t < rise + carry) return interpolate(up, over, zero, (t - rise) / carry);
                         return interpolate(over, p.onto, zero, std::min(1.0, (t - rise - carry) / lower));
                       }});
  }

  void tumble(const BodyInfo& info, Shape shape, Texture texture) {
    const Eigen::Vector3f half = half_extents(info);
    const float hh = half_height(info), reach = half.norm();
    const float drift = draw.f(0.05, 0.10);
    Eigen::Vector2f xy, to;
    for (int tries = 0; tries < 100; ++tries) {
      free_spot(reach, xy);
      const float heading = draw.f(-kPi, kPi);
      to = xy + drift * Eigen::Vector2f(std::cos(heading), std::sin(heading));
      if (in_area(to, reach)) break;
      to = xy;
    }
    sweep(xy, to, reach);
    const float yaw0 = draw.f(-kPi, kPi);
    const Iso rest = at(xy.x(), xy.y(), hh, yaw0);
    const bool about_x = draw(0.0, 1.0) < 0.5;
    const Eigen::Vector3f body_axis = about_x ? Eigen::Vector3f::UnitX() : Eigen::Vector3f::UnitY();
    const Eigen::Vector3f tumble_axis = rest.linear() * body_axis;
    const Eigen::Vector3f rock_axis = rest.linear() * (about_x ? Eigen::Vector3f::UnitY() : Eigen::Vector3f::UnitX());
    // A box lands on whichever face the quarter turns put down; other shapes turn twice, landing upright.
    const int quarters = shape == Shape::box ? 8 + draw.index(4) : 8;
    const float tumble = random_sign() * quarters * 0.5f * kPi;
    // Rocking would swing a gripper's rod (along the tumble axis) down to the table: none then.
    const float rock = random_sign() * draw.f(0.8, 1.2) * (mover == Mover::gripper ? 0.0f : 1.0f);
    const float lift = lift_for(half, hh, 0.06f);
    const double rise = frames_of(std::max(0.8, 1.5 * lift / kMaxLinearSpeed));
    const double turn = frames_of(1.5 * std::hypot(tumble, 2.0f * kPi * rock) / kPeakTurn);
    Iso landed = rest;
    landed.linear() = Eigen::AngleAxisf(tumble, tumble_axis).toRotationMatrix() * rest.linear();
    landed.translation() = Eigen::Vector3f(to.x(), to.y(), 0.0f);
    landed.translation().z() = landed.linear().row(2).cwiseAbs().dot(half);
    Iso above_landing = landed;
    above_landing.translation().z() = hh + lift;
    const double lower = frames_of(std::max(0.8, min_move_duration(above_landing, landed, Eigen::Vector3f::Zero())));
    duration = rise + turn + lower;
    summary.spin_axis = body_axis;
    summary.spin_angle_rad = tumble;
    grasp_axis = body_axis;
    const int body = add_object(info, shape, texture, rest, true);
    members.push_back({body, [=](double t) {
                         if (t >= rise + turn) {
                           return interpolate(above_landing, landed, Eigen::Vector3f::Zero(),
                                              std::min(1.0, (t - rise - turn) / lower));
                         }
                         Iso pose = rest;
                         pose.translation().z() += static_cast<float>(eased(t, rise)) * lift;
                         const auto s = static_cast<float>(eased(t - rise, turn));
                         pose.linear() =
                             Eigen::AngleAxisf(s * tumble, tumble_axis).toRotationMatrix() *
                             Eigen::AngleAxisf(rock * std::sin(2.0f * kPi * s), rock_axis).toRotationMatrix() *
                             rest.linear();
                         pose.translation().head<2>() = xy + s * (to - xy);
                         return pose;
                       }});
  }

  float random_sign() { return draw(0.0, 1.0) < 0.5 ? -1.0f : 1.0f; }

  // Reserves the table area under the mover (body info, frame grip in the held body's frame) at
  // the held body's poses: points of its primitives (every 4 cm) lower than any object can reach.
  void reserve_mover(const BodyInfo& body, const Iso& grip, const std::vector<Iso>& held_poses) {
    constexpr float kStep = 0.04f, kHighest = 0.33f;
    for (const Iso& held : held_poses) {
      const Iso m = held * grip;
      for (const Primitive& prim : body.primitives) {
        const Iso to_world = m * prim.pose.isometry();
        std::array<int, 3> n{};
        for (int i = 0; i < 3; ++i) n[i] = 1 + static_cast<int>(std::ceil(prim.size[i] / kStep));
        for (int i = 0; i < n[0]; ++i) {
          for (int j = 0; j < n[1]; ++j) {
            for (int k = 0; k < n[2]; ++k) {
              const Eigen::Vector3f f(n[0] > 1 ? static_cast<float>(i) / (n[0] - 1) - 0.5f : 0.0f,
                                      n[1] > 1 ? static_cast<float>(j) / (n[1] - 1) - 0.5f : 0.0f,
                                      n[2] > 1 ? static_cast<float>(k) / (n[2] - 1) - 0.5f : 0.0f);
              const Eigen::Vector3f w = to_world * f.cwiseProduct(prim.size);
              if (w.z() < kHighest) taken.push_back({w.head<2>(), 0.75f * kStep});
            }
          }
        }
      }
    }
  }

  static BodyInfo shrunk(const BodyInfo& info, float factor) {
    BodyInfo out = info;
    for (Primitive& p : out.primitives) {
      p.size *= factor;
      p.pose.translation *= factor;
    }
    return out;
  }

  Eigen::Vector3f grasp_axis = Eigen::Vector3f::UnitZ();  // body frame: the gripper's rod direction
};

}  // namespace

Script procedural_scenario(const ScenarioOptions& options, int attempt) {
  Generator g(options.seed * 0x9e3779b97f4a7c15ULL + static_cast<std::uint64_t>(attempt) * 0x2545f4914f6cdd1dULL +
              0x9b0cedULL);
  Draw& draw = g.draw;
  SceneSummary& summary = g.summary;

  // 1. Camera.
  const float pitch = draw.f(35.0, 65.0) * kDeg, distance = draw.f(0.8, 1.1);
  World world = make_world(pitch, distance, Eigen::Vector3f(draw.f(-0.03, 0.03), draw.f(0.05, 0.12), 0.0f));
  summary.camera_pitch_rad = pitch;
  summary.camera_height_m = distance * std::sin(pitch);

  // 2. Motion class and mover.
  const auto motion = static_cast<Motion>(draw.index(static_cast<int>(kMotionNames.size())));
  const bool turns_whole = motion == Motion::spin || motion == Motion::tumble;
  // A hand grasps from above and keeps upright: it moves objects on or over the table (slide,
  // push, stack); turns are a gripper's.
  const bool hand_ok = motion == Motion::slide || motion == Motion::push || motion == Motion::stack;
  Mover mover = !hand_ok || turns_whole ? (draw(0.0, 1.0) < 0.5 ? Mover::gripper : Mover::none)
                                        : static_cast<Mover>(draw.index(3));

  // 3. Object count and the moved objects.
  const int own = motion == Motion::push ? 2 + draw.index(2) : motion == Motion::stack ? 2 : 1;
  const double u = draw(0.0, 1.0);
  const int count = std::clamp(1 + static_cast<int>(std::floor(kMaxObjects * u * u)), own, kMaxObjects);
  std::vector<Shape> shapes;
  std::vector<Texture> textures;
  std::vector<BodyInfo> infos;
  for (int k = 0; k < own; ++k) {
    Shape shape = g.any_shape();
    if (motion == Motion::stack && k == 1) shape = draw(0.0, 1.0) < 0.5 ? Shape::box : Shape::can;  // a flat top
    if (motion == Motion::spin && draw(0.0, 1.0) < 0.4) shape = draw(0.0, 1.0) < 0.5 ? Shape::can : Shape::bottle;
    shapes.push_back(shape);
    textures.push_back(g.any_texture());
    infos.push_back(make_shape(draw, k + 1, shape, textures.back(), 1.0f));
  }
  // The hand's fingers hang 9 cm below its palm: shorter objects are held by the gripper.
  if (mover == Mover::hand && 2.0f * half_height(infos[0]) < 0.09f) mover = Mover::gripper;
  g.mover = mover;
  summary.motion = kMotionNames[static_cast<int>(motion)];
  summary.mover = kMoverNames[static_cast<int>(mover)];

  // 4. Layout of the moved objects, then of the others.
  switch (motion) {
    case Motion::slide:
      g.slide(infos[0], shapes[0], textures[0]);
      break;
    case Motion::push:
      g.push(own, infos, shapes, textures);
      break;
    case Motion::spin:
      g.spin(infos[0], shapes[0], textures[0]);
      break;
    case Motion::tilt:
      g.tilt(infos[0], shapes[0], textures[0]);
      break;
    case Motion::stack:
      g.stack(infos[0], shapes[0], textures[0], infos[1], shapes[1], textures[1]);
      break;
    case Motion::tumble:
      g.tumble(infos[0], shapes[0], textures[0]);
      break;
  }
  // The mover's grip (its frame in the held body's frame) and the table area under it.
  ScriptBuilder& b = g.builder;
  const int held_body = motion == Motion::stack ? g.stack_plan.moved : g.members.front().body;
  const BodyInfo held_info = b.info(held_body);
  const Iso start_pose = motion == Motion::stack ? g.stack_plan.from : g.members.front().pose(0.0);
  Iso grip = Iso::Identity();
  BodyInfo mover_info;
  Iso mover_home = Iso::Identity();
  const float hand_side = start_pose.translation().x() < 0.0f ? -1.0f : 1.0f;  // the mover's table side
  if (mover == Mover::hand) {
    // Fingers point into the table from the nearer side; when pushing, across the push.
    float heading = hand_side < 0.0f ? 0.0f : kPi;
    if (motion == Motion::push) {
      heading = g.push_heading + 0.5f * kPi;
      if (std::cos(heading) * hand_side > 0.0f) heading += kPi;
    }
    const float yaw0 = std::atan2(start_pose.linear()(1, 0), start_pose.linear()(0, 0));
    grip = top_grasp(held_info, Iso::Identity(), heading - yaw0);
    mover_info = make_hand(kMoverId);
  } else if (mover == Mover::gripper) {
    Eigen::Vector3f axis = g.grasp_axis;
    // A turn's rod leaves upwards (away from the camera when the axis is horizontal); tilt's side
    // is set by the tilt.
    const Eigen::Vector3f world_axis = start_pose.linear() * axis;
    if (turns_whole && (world_axis.z() < -1e-4f || (std::abs(world_axis.z()) <= 1e-4f && world_axis.y() < 0.0f))) {
      axis = -axis;
    }
    float grip_half = 0.0f, finger = 0.0f;
    grip = gripper_offset(half_extents(held_info), axis, grip_half, finger);
    mover_info = make_gripper(kMoverId, grip_half, finger);
  }
  if (mover != Mover::none) {
    std::vector<Iso> held_poses;
    if (motion == Motion::stack) {
      held_poses = {g.stack_plan.from, g.stack_plan.onto};
    } else {
      for (double t = 0.0; t < g.duration + 0.2; t += 0.2)
        held_poses.push_back(g.members.front().pose(std::min(t, g.duration)));
    }
    g.reserve_mover(mover_info, grip, held_poses);
  }

  float scale = 1.0f;
  int next_id = own + 1;
  float tallest = 0.0f;
  for (const BodyInfo& info : infos) tallest = std::max(tallest, 2.0f * half_height(info));
  for (int k = own; k < count; ++k) {
    const Shape shape = g.any_shape();
    const Texture texture = g.any_texture();
    const BodyInfo drawn = make_shape(draw, next_id, shape, texture, 1.0f);
    for (; scale >= 0.5f; scale *= 0.85f) {
      const BodyInfo info = scale < 1.0f ? Generator::shrunk(drawn, scale) : drawn;
      const float r = footprint_radius(info);
      Eigen::Vector2f xy;
      if (!g.free_spot(r, xy)) continue;
      g.taken.push_back({xy, r});
      g.add_object(info, shape, texture, at(xy.x(), xy.y(), half_height(info), draw.f(-kPi, kPi)), false);
      tallest = std::max(tallest, 2.0f * half_height(info));
      ++next_id;
      break;
    }
  }
  if (motion == Motion::stack) g.stack_programme(tallest);

  // 5. and 6. The mover's approach, the programme keyed at every frame, the withdrawal.
  const Member& held = g.members.front();
  // Straight above the grasp, over every object: a hand's palm 15 cm over the tallest (its fingers
  // hang 9 cm), a gripper's palm 12 cm (its fingers reach 5 cm).
  auto hover_over = [&](const Iso& grasp) {
    Iso hover = grasp;
    hover.translation().z() =
        std::max(grasp.translation().z() + 0.08f, tallest + (mover == Mover::hand ? 0.15f : 0.12f));
    return hover;
  };
  // Where the mover waits, out of the image at the nearer table side and as high as its hover: the
  // way in and out runs over every object.
  auto home_of = [&](const Iso& hover) {
    const float z = std::max(0.35f, hover.translation().z());
    if (mover == Mover::gripper) {
      Iso home = hover;
      home.translation() = Eigen::Vector3f(hand_side * 0.75f, hover.translation().y(), z);
      return home;
    }
    return at(hand_side * 0.75f, hover.translation().y(), z, hand_side < 0.0f ? 0.0f : kPi);
  };
  int mover_body = -1;
  if (mover != Mover::none) {
    mover_home = home_of(hover_over(start_pose * grip));
    mover_body = b.add_body(mover_info, mover_home);
  }
  const Eigen::Vector3f zero = Eigen::Vector3f::Zero();
  double t_start = frames_of(draw(0.5, 1.0));
  if (mover_body >= 0) {
    const Iso grasp = start_pose * grip;
    const Iso hover_start = hover_over(grasp);
    const double reach = frames_of(std::max(0.8, min_move_duration(mover_home, hover_start, zero)));
    const double down = frames_of(std::max(0.5, min_move_duration(hover_start, grasp, zero)));
    const double t0 = frames_of(draw(0.3, 0.8));
    b.key(mover_body, t0, mover_home);
    b.key(mover_body, t0 + reach, hover_start);
    b.key(mover_body, t0 + reach + down, grasp);
    t_start = t0 + reach + down + frames_of(0.3);
  }
  const int first = static_cast<int>(std::lround(t_start * kFps));
  const int steps = static_cast<int>(std::ceil(g.duration * kFps - 1e-6));
  for (int k = 0; k <= steps; ++k) {
    const double t = std::min(g.duration, k / kFps);
    const double when = (first + k) / kFps;
    for (const Member& m : g.members) b.key(m.body, when, m.pose(t), Profile::linear);
    if (mover_body >= 0) b.key(mover_body, when, held.pose(t) * grip, Profile::linear);
  }
  double t_end = (first + steps) / kFps;
  if (mover_body >= 0) {
    const Iso grasp = held.pose(g.duration) * grip;
    const Iso hover = hover_over(grasp);
    const Iso home = home_of(hover);
    const double up = frames_of(std::max(0.5, min_move_duration(grasp, hover, zero)));
    const double away = frames_of(std::max(0.8, min_move_duration(hover, home, zero)));
    const double hold = frames_of(0.3);
    b.key(mover_body, t_end + hold, grasp);
    b.key(mover_body, t_end + hold + up, hover);
    b.key(mover_body, t_end + hold + up + away, home);
    t_end += hold + up + away;
  }
  b.wait(t_end);
  Script script = b.finish(frames_of(draw(0.5, 1.0)));
  script.world = std::move(world);
  script.summary = std::move(summary);
  return script;
}

}  // namespace mfot::sim::detail
