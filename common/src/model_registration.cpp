// Global registration of a known model on new points (steps in the header).

#include "mfot/model_registration.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <random>
#include <stdexcept>
#include <string>

#include "mfot/hypothesis.hpp"
#include "mfot/particle_filter.hpp"

namespace mfot {

namespace {

const ModelRegistrationOptions& validated(const ModelRegistrationOptions& options) {
  options.validate();
  return options;
}

JcsdLikelihoodOptions likelihood_options(const ModelRegistrationOptions& options) {
  JcsdLikelihoodOptions o;
  o.grid.cell_size = options.cell_size;
  return o;
}

// Rotations uniform over SO(3) (Shoemake 1992) from the generator's own bits (identical on every
// platform).
std::vector<Eigen::Quaternionf> uniform_rotations(int count, std::uint64_t seed) {
  std::mt19937_64 gen(seed);
  auto uniform = [&gen] { return static_cast<double>(gen() >> 11) * 0x1.0p-53; };
  std::vector<Eigen::Quaternionf> out;
  out.reserve(static_cast<std::size_t>(count));
  for (int k = 0; k < count; ++k) {
    const double u1 = uniform(), u2 = 2.0 * std::numbers::pi * uniform(), u3 = 2.0 * std::numbers::pi * uniform();
    const double a = std::sqrt(1.0 - u1), b = std::sqrt(u1);
    out.emplace_back(static_cast<float>(b * std::cos(u3)), static_cast<float>(a * std::sin(u2)),
                     static_cast<float>(a * std::cos(u2)), static_cast<float>(b * std::sin(u3)));
    out.back().normalize();
  }
  return out;
}

// Depth below a z-buffer cell's nearest model point that still belongs to the near side, in
// match distances.
constexpr float kNearSideDepth = 1.f;
// Translation alignment per rotation hypothesis: iterations, the radius within which a point's
// nearest model point counts (metres), and about how many points it samples.
constexpr int kAlignIterations = 3;
constexpr float kAlignRadius = 0.03f;
constexpr std::size_t kAlignPoints = 256;
constexpr float kFirstTranslationStep = 0.01f;                                 // metres
constexpr float kFirstRotationStep = 8.f * std::numbers::pi_v<float> / 180.f;  // radians

}  // namespace

void ModelRegistrationOptions::validate() const {
  auto require = [](bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument("ModelRegistrationOptions." + what);
  };
  require(rotations >= 1 && rotations <= 100000, "rotations must be in [1, 100000], got " + std::to_string(rotations));
  require(candidates >= 1 && candidates <= 64, "candidates must be in [1, 64], got " + std::to_string(candidates));
  require(refine_rounds >= 0 && refine_rounds <= 100,
          "refine_rounds must be in [0, 100], got " + std::to_string(refine_rounds));
  require(min_fit >= 0.f && min_fit <= 1.f, "min_fit must be in [0, 1], got " + std::to_string(min_fit));
  require(cell_size >= 0.001f && cell_size <= 0.2f,
          "cell_size must be in [0.001, 0.2] metres, got " + std::to_string(cell_size));
  fit.validate();
}

ModelRegistration::ModelRegistration(const ModelRegistrationOptions& options)
    : options_(validated(options)),
      rotations_(uniform_rotations(options.rotations, options.seed)),
      likelihood_(likelihood_options(options)),
      fit_(options.fit),
      align_hash_(kAlignRadius) {}

void ModelRegistration::align_translation(const ObjectModel& model, const HypothesisData& points, int iterations,
                                          Pose& pose) const {
  const std::size_t stride = std::max<std::size_t>(1, points.points.size() / kAlignPoints);
  const Eigen::Matrix3f to_object = pose.rotation.conjugate().toRotationMatrix();
  for (int iteration = 0; iteration < iterations; ++iteration) {
    Eigen::Vector3f offset = Eigen::Vector3f::Zero();
    int matched = 0;
    for (std::size_t k = 0; k < points.points.size(); k += stride) {
      const Eigen::Vector3f local = to_object * (points.points[k] - pose.translation);
      const int nearest = align_hash_.nearest(local, kAlignRadius);
      if (nearest < 0) continue;
      offset += points.points[k] -
                (pose.rotation * model.cloud.positions[static_cast<std::size_t>(nearest)] + pose.translation);
      ++matched;
    }
    if (matched == 0) return;
    pose.translation += offset / static_cast<float>(matched);
  }
}

std::optional<Registration> ModelRegistration::register_model(const ObjectModel& model, const HypothesisData& points,
                                                              const std::optional<Eigen::Quaternionf>& prior) {
  if (points.features.size() != points.points.size()) {
    throw std::invalid_argument("ModelRegistration: the points need one SMR feature each");
  }
  const Eigen::AlignedBox3f box = model_bounding_box(model);
  if (points.points.empty() || box.isEmpty()) return std::nullopt;
  likelihood_.set_model(model);
  // The grid spans the model's box (megabytes for a large model) and registrations are rare (an
  // object seen again): it is released on every return, so the memory held between registrations
  // does not grow with the largest model ever registered.
  struct ReleaseGrid {
    JcsdLikelihood& likelihood;
    ~ReleaseGrid() { likelihood.set_grid(JcsdGrid{}); }
  } release_grid{likelihood_};

  // 1. Coarse hypotheses.
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
  for (const Eigen::Vector3f& p : points.points) centroid += p;
  centroid /= static_cast<float>(points.points.size());
  const Eigen::Vector3f sight = centroid.normalized();  // camera at the origin
  const Eigen::Vector3f across = sight.unitOrthogonal(), up = sight.cross(across);
  float radius = 0.f;  // of the model about its origin
  for (const Eigen::Vector3f& m : model.cloud.positions) radius = std::max(radius, m.norm());
  hypotheses_.clear();
  align_hash_.build(model.cloud.positions);
  auto place = [&](const Eigen::Quaternionf& rotation) {
    // The model's near side under this rotation: per cell across the line of sight, the points
    // within kNearSideDepth of the cell's nearest one (an orthographic z-buffer; a face seen
    // obliquely spans some depth per cell), weighted per surface area like the voxelised scene.
    const float cell = options_.fit.match_distance;
    const int side = 2 * static_cast<int>(std::ceil(radius / cell)) + 1;
    auto cell_of = [&](const Eigen::Vector3f& q) {
      const int u = std::clamp(static_cast<int>(std::floor(q.dot(across) / cell)) + side / 2, 0, side - 1);
      const int v = std::clamp(static_cast<int>(std::floor(q.dot(up) / cell)) + side / 2, 0, side - 1);
      return static_cast<std::size_t>(v * side + u);
    };
    nearest_.assign(static_cast<std::size_t>(side * side), std::numeric_limits<float>::infinity());
    turned_.clear();
    for (const Eigen::Vector3f& m : model.cloud.positions) {
      const Eigen::Vector3f q = rotation * m;
      turned_.push_back(q);
      float& nearest = nearest_[cell_of(q)];
      nearest = std::min(nearest, q.dot(sight));
    }
    Eigen::Vector3f near_side = Eigen::Vector3f::Zero();
    int count = 0;
    for (const Eigen::Vector3f& q : turned_) {
      if (q.dot(sight) <= nearest_[cell_of(q)] + kNearSideDepth * cell) {
        near_side += q;
        ++count;
      }
    }
    Pose p;
    p.rotation = rotation;
    p.translation = centroid - near_side / static_cast<float>(count);
    align_translation(model, points, kAlignIterations, p);
    hypotheses_.push_back(p);
  };
  if (prior) place(prior->normalized());
  for (const Eigen::Quaternionf& r : rotations_) place(r);
  // 2. Score them.
  scores_.resize(hypotheses_.size());
  likelihood_.evaluate(hypotheses_, points, scores_);
  std::vector<std::size_t> order(hypotheses_.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  const auto kept = std::min(order.size(), static_cast<std::size_t>(options_.candidates));
  // Stable on ties: the earlier hypothesis (the prior's) wins.
  std::partial_sort(
      order.begin(), order.begin() + static_cast<std::ptrdiff_t>(kept), order.end(),
      [&](std::size_t a, std::size_t b) { return scores_[a] > scores_[b] || (scores_[a] == scores_[b] && a < b); });

  // 3. Pattern search from each; a pose's score is kept from the evaluation that chose it.
  Pose best;
  float best_score = -std::numeric_limits<float>::infinity();
  std::array<Pose, kPatternMoves> moves;
  std::array<float, kPatternMoves> move_scores{};
  for (std::size_t candidate = 0; candidate < kept; ++candidate) {
    Pose current = hypotheses_[order[candidate]];
    float current_score = scores_[order[candidate]];
    float translation = kFirstTranslationStep, rotation = kFirstRotationStep;
    for (int round = 0; round < options_.refine_rounds; ++round) {
      pattern_moves(current, translation, rotation, moves);
      // A turn about the origin moves the near side: re-centre it on the points.
      for (std::size_t m = 7; m < kPatternMoves; ++m) align_translation(model, points, 1, moves[m]);
      likelihood_.evaluate(moves, points, move_scores);
      // The first of equal scores wins: the pose stays unless a move scores higher.
      const auto winner =
          static_cast<std::size_t>(std::max_element(move_scores.begin(), move_scores.end()) - move_scores.begin());
      if (winner == 0) {
        translation *= 0.5f;
        rotation *= 0.5f;
      }
      current = moves[winner];
      current_score = move_scores[winner];
    }
    if (current_score > best_score) {
      best_score = current_score;
      best = current;
    }
  }

  // 4. Accept.
  const float fit = fit_.fit(points, model, box, best);
  if (fit < options_.min_fit) return std::nullopt;
  return Registration{best, fit};
}

}  // namespace mfot
