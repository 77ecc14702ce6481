// A model version as an edit of the one before (model_delta.hpp, object_model_t's is_delta): the edit the
// merger sends, through the wire, gives the receiver the model bit for bit for every kind of change the merger
// makes (growth, thinning, a re-fitted part, the forgetting update); it is sent only when smaller than the
// whole model; and a forged or corrupt edit is refused with the problem named, without a crash.

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "encoded_message.hpp"
#include "mfot/object_model_t.hpp"
#include "mfot/service/convert.hpp"
#include "mfot/service/merger_messages.hpp"
#include "mfot/service/model_delta.hpp"

namespace mfot::service {
namespace {

using testing::encode;

ColoredCloud random_cloud(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> coordinate(-0.1f, 0.1f);
  std::uniform_int_distribution<int> channel(0, 255);
  ColoredCloud cloud;
  for (std::size_t i = 0; i < n; ++i) {
    cloud.push_back({coordinate(rng), coordinate(rng), coordinate(rng)},
                    Rgb8{static_cast<std::uint8_t>(channel(rng)), static_cast<std::uint8_t>(channel(rng)),
                         static_cast<std::uint8_t>(channel(rng))});
  }
  return cloud;
}

bool same_bits(const ColoredCloud& a, const ColoredCloud& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (std::memcmp(a.positions[i].data(), b.positions[i].data(), 3 * sizeof(float)) != 0) return false;
    if (a.colors[i].r != b.colors[i].r || a.colors[i].g != b.colors[i].g || a.colors[i].b != b.colors[i].b) {
      return false;
    }
  }
  return true;
}

ManagedObject object_with(const ColoredCloud& cloud, std::int32_t version) {
  ManagedObject object;
  object.id = 7;
  object.version = version;
  object.model.cloud = cloud;
  object.pose.translation = Eigen::Vector3f(0.1f, 0.f, 0.9f);
  return object;
}

// The model message for the owner that holds `base` (version 3), through the wire, and what the owner
// makes of it.
struct Sent {
  object_model_t msg;
  ObjectModel received;
  std::optional<std::string> error;
};
Sent send(const ColoredCloud& base, const ColoredCloud& model, std::span<const Eigen::Vector3f> claimed = {}) {
  ModelDiffer differ;
  const HeldModel held{3, base};
  const object_model_t out = model_message(object_with(model, 4), 2, 22, 10, claimed, 0, &held, differ);
  Sent sent;
  const testing::Bytes bytes = encode(out);
  EXPECT_EQ(sent.msg.decode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  Pose pose;
  PoseVector velocity;
  sent.error = model_from_message(sent.msg, sent.received, pose, velocity, &base);
  return sent;
}

TEST(ModelDelta, EveryKindOfModelChangeArrivesBitForBitAsAnEditSmallerThanTheWholeModel) {
  const ColoredCloud base = random_cloud(1200, 1);
  const ColoredCloud gained = random_cloud(90, 2);
  std::vector<std::pair<const char*, ColoredCloud>> changes;
  {
    ColoredCloud grown = base;  // growth: points appended
    for (std::size_t i = 0; i < gained.size(); ++i) grown.push_back(gained.positions[i], gained.colors[i]);
    changes.emplace_back("grown", grown);
    ColoredCloud thinned;  // grown past the size limit, then thinned evenly
    for (std::size_t i = 0; i < grown.size(); ++i) {
      if (i % 13 != 5) thinned.push_back(grown.positions[i], grown.colors[i]);
    }
    changes.emplace_back("grown and thinned", thinned);
  }
  {
    ColoredCloud refit = base;  // a part re-fitted: its points moved in place
    for (std::size_t i = 400; i < 520; ++i) refit.positions[i] += Eigen::Vector3f(0.001f, -0.002f, 0.0005f);
    changes.emplace_back("part moved", refit);
  }
  {
    std::mt19937_64 rng(3);  // the forgetting update: a random share dropped, new points appended
    ColoredCloud mixed;
    for (std::size_t i = 0; i < base.size(); ++i) {
      if (rng() % 50 != 0) mixed.push_back(base.positions[i], base.colors[i]);
    }
    for (std::size_t i = 0; i < 24; ++i) mixed.push_back(gained.positions[i], gained.colors[i]);
    changes.emplace_back("forgetting update", mixed);
  }
  {
    ColoredCloud duplicates = base;  // points repeated to the bit, and one reordered
    duplicates.positions[10] = duplicates.positions[9];
    duplicates.colors[10] = duplicates.colors[9];
    std::swap(duplicates.positions[100], duplicates.positions[700]);
    std::swap(duplicates.colors[100], duplicates.colors[700]);
    changes.emplace_back("duplicates and a swap", duplicates);
  }
  for (const auto& [name, model] : changes) {
    SCOPED_TRACE(name);
    const std::vector<Eigen::Vector3f> claimed(200, Eigen::Vector3f(0.2f, 0.f, 1.f));
    const Sent sent = send(base, model, claimed);
    ASSERT_FALSE(sent.error) << *sent.error;
    EXPECT_TRUE(sent.msg.is_delta);
    EXPECT_EQ(sent.msg.base_version, 3);
    EXPECT_EQ(sent.msg.version, 4);
    EXPECT_EQ(sent.msg.num_claimed, 0);  // the frame's end carries them
    EXPECT_LT(sent.msg.num_points, static_cast<std::int32_t>(model.size() / 4));
    EXPECT_TRUE(same_bits(sent.received.cloud, model));
    EXPECT_EQ(sent.received.features.size(), model.size());
  }
}

TEST(ModelDelta, AWholeModelGoesWhenTheEditIsNotSmallerOrNothingIsHeld) {
  const ColoredCloud base = random_cloud(300, 1);
  const ColoredCloud unrelated = random_cloud(310, 9);
  const Sent sent = send(base, unrelated);
  ASSERT_FALSE(sent.error) << *sent.error;
  EXPECT_FALSE(sent.msg.is_delta);
  EXPECT_EQ(sent.msg.base_version, 0);
  EXPECT_EQ(sent.msg.num_base_runs, 0);
  EXPECT_EQ(sent.msg.num_points, 310);
  EXPECT_TRUE(same_bits(sent.received.cloud, unrelated));
  ModelDiffer differ;
  const object_model_t whole = model_message(object_with(base, 4), 2, 22, 10, {}, 0, nullptr, differ);
  EXPECT_FALSE(whole.is_delta);
  EXPECT_EQ(whole.num_points, 300);
  // A held version not below the model's is no base.
  const HeldModel same{4, base};
  EXPECT_FALSE(model_message(object_with(base, 4), 2, 22, 10, {}, 0, &same, differ).is_delta);
}

TEST(ModelDelta, AForgedOrCorruptEditIsRefusedWithTheProblemNamed) {
  const ColoredCloud base = random_cloud(100, 1);
  ColoredCloud model = base;
  model.push_back({0.01f, 0.02f, 0.03f}, Rgb8{1, 2, 3});
  const Sent good = send(base, model);
  ASSERT_FALSE(good.error);
  ASSERT_TRUE(good.msg.is_delta);
  const auto refused = [&base](const object_model_t& msg, const ColoredCloud* with_base, const char* what) {
    SCOPED_TRACE(what);
    ObjectModel out;
    Pose pose;
    PoseVector velocity;
    const auto error = model_from_message(msg, out, pose, velocity, with_base);
    EXPECT_TRUE(error.has_value());
    (void)base;
  };
  const auto edited = [&good](auto change) {
    object_model_t msg = good.msg;
    change(msg);
    return msg;
  };
  refused(good.msg, nullptr, "no base held (a report to the merger must be whole)");
  const ColoredCloud shorter = random_cloud(99, 1);
  refused(good.msg, &shorter, "a base of another size");
  refused(edited([](object_model_t& m) { m.base_version = 4; }), &base, "base_version not below version");
  refused(edited([](object_model_t& m) { m.base_version = -1; }), &base, "negative base_version");
  refused(edited([](object_model_t& m) { m.base_runs[0] = -5; }), &base, "negative run");
  refused(edited([](object_model_t& m) { m.base_runs[0] -= 1; }), &base, "base runs short of the base");
  refused(edited([](object_model_t& m) { m.base_runs[0] = 2147483647; }), &base, "base runs overflowing");
  refused(edited([](object_model_t& m) { m.order_runs[0] -= 1; }), &base, "order runs keeping fewer");
  refused(edited([](object_model_t& m) { m.order_runs[1] += 1; }), &base, "more new points than sent");
  refused(edited([](object_model_t& m) { m.num_order_runs += 1; }), &base, "run count disagreeing with its array");
  refused(edited([](object_model_t& m) { m.x[0] = std::numeric_limits<float>::quiet_NaN(); }), &base,
          "non-finite new point");
  refused(edited([](object_model_t& m) { m.x[0] = 2.f; }), &base, "new point beyond the model radius");
  refused(edited([](object_model_t& m) {
            m.num_claimed = 1;
            m.claimed_x = m.claimed_y = m.claimed_z = {0.f};
          }),
          &base, "claimed points in an edit");
  refused(edited([](object_model_t& m) { m.is_delta = false; }), nullptr, "a whole model with an edit's fields");
}

TEST(ModelDelta, RandomEditsAssembleExactlyWhatTheyCountOrAreRefused) {
  // Valid random edits, half of them with one run changed at random: each is refused, or assembles the
  // points its runs pick, in order.
  const ColoredCloud base = random_cloud(40, 1);
  const ColoredCloud fresh = random_cloud(6, 2);
  std::mt19937_64 rng(5);
  int assembled = 0, refused = 0;
  for (int trial = 0; trial < 5000; ++trial) {
    std::vector<std::int32_t> base_runs, order_runs;
    std::vector<bool> kept_base;
    for (std::size_t left = base.size(); left > 0;) {
      const auto run = std::min<std::size_t>(left, rng() % 8);
      base_runs.push_back(static_cast<std::int32_t>(run));
      kept_base.insert(kept_base.end(), run, base_runs.size() % 2 == 1);
      left -= run;
    }
    std::int32_t kept = 0;
    for (std::size_t k = 0; k < base_runs.size(); k += 2) kept += base_runs[k];
    for (std::int32_t kept_left = kept, new_left = 6; kept_left + new_left > 0;) {
      const bool is_new = order_runs.size() % 2 == 1;
      std::int32_t& left = is_new ? new_left : kept_left;
      const auto run = std::min<std::int32_t>(left, static_cast<std::int32_t>(rng() % 5));
      order_runs.push_back(run);
      left -= run;
    }
    const bool forged = trial % 2 == 1;
    if (forged) {
      std::vector<std::int32_t>& runs = rng() % 2 == 0 || order_runs.empty() ? base_runs : order_runs;
      if (runs.empty()) continue;
      runs[rng() % runs.size()] += static_cast<std::int32_t>(rng() % 7) - 3;
    }
    ColoredCloud out;
    if (apply_model_delta(base, base_runs, order_runs, fresh, out)) {
      ++refused;
      EXPECT_TRUE(out.empty());
      continue;
    }
    ++assembled;
    ColoredCloud expected;  // the kept base points and the new ones, in the order the runs give
    std::size_t next_base = 0, next_new = 0;
    for (std::size_t k = 0; k < order_runs.size(); ++k) {
      for (std::int32_t n = 0; n < order_runs[k]; ++n) {
        if (k % 2 == 1) {
          expected.push_back(fresh.positions[next_new], fresh.colors[next_new]);
          ++next_new;
          continue;
        }
        while (!kept_base[next_base]) ++next_base;
        expected.push_back(base.positions[next_base], base.colors[next_base]);
        ++next_base;
      }
    }
    EXPECT_TRUE(same_bits(out, expected)) << trial;  // a forged run that passed changed by 0
  }
  EXPECT_GT(assembled, 2500);
  EXPECT_GT(refused, 1000);
}

}  // namespace
}  // namespace mfot::service
