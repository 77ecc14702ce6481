#include <gtest/gtest.h>

#include <vector>

#include "mfot/discovery_confirmation.hpp"

namespace mfot {
namespace {

DiscoveryOptions confirm_options() {
  DiscoveryOptions o;
  o.confirm_frames = 5;
  o.confirm_votes = 2;
  return o;
}

// Scene points 0-9 labelled 1, 10-19 labelled 2, 20-29 labelled 0.
std::vector<std::int32_t> labels() {
  std::vector<std::int32_t> out(30, 0);
  for (int i = 0; i < 20; ++i) out[static_cast<std::size_t>(i)] = i < 10 ? 1 : 2;
  return out;
}

std::vector<int> range(int begin, int end) {
  std::vector<int> out;
  for (int i = begin; i < end; ++i) out.push_back(i);
  return out;
}

TEST(DiscoveryConfirmation, PartsThatAgreeWithTheObjectsMatchOneToOne) {
  const auto match = DiscoveryConfirmation::match({range(0, 10), range(10, 20)}, labels());
  EXPECT_EQ(match.member_of_part, (std::vector<std::int32_t>{1, 2}));
  EXPECT_FALSE(match.disagrees(3));
}

TEST(DiscoveryConfirmation, APieceOfAnObjectInAnothersPartDisagrees) {
  // Part 0 holds object 1 and half of object 2, part 1 the rest of object 2.
  const auto match = DiscoveryConfirmation::match({range(0, 15), range(15, 20)}, labels());
  EXPECT_EQ(match.member_of_part, (std::vector<std::int32_t>{1, 2}));
  EXPECT_TRUE(match.disagrees(5));
  EXPECT_FALSE(match.disagrees(6));  // a smaller piece than asked for
}

TEST(DiscoveryConfirmation, OnePartForTwoObjectsIsLeftToTheSiblingWatch) {
  // The discovery sees objects 1 and 2 as one part: the parts do not disagree (no object is cut wrongly); whether
  // the two are one object is the sibling watch's question (unparted_siblings).
  const auto match = DiscoveryConfirmation::match({range(0, 20)}, labels());
  EXPECT_EQ(match.member_of_part, (std::vector<std::int32_t>{1}));  // equal overlaps: the lower id
  EXPECT_FALSE(match.disagrees(1));
}

TEST(DiscoveryConfirmation, APartNoObjectTookDisagrees) {
  // Object 1 cut in two parts (points 0-5 and 6-9): the smaller part is left untaken.
  const auto match = DiscoveryConfirmation::match({range(0, 6), range(6, 10), range(10, 20)}, labels());
  EXPECT_EQ(match.member_of_part, (std::vector<std::int32_t>{1, 0, 2}));
  EXPECT_TRUE(match.disagrees(100));
}

TEST(DiscoveryConfirmation, AdoptsOnceThePartsDisagreedInConfirmVotesFrames) {
  DiscoveryConfirmation confirmation(confirm_options());
  EXPECT_FALSE(confirmation.vote(4, true));
  EXPECT_FALSE(confirmation.vote(4, false));  // agreeing frames do not count
  EXPECT_FALSE(confirmation.vote(9, true));   // another birth counts apart
  EXPECT_TRUE(confirmation.vote(4, true));
  EXPECT_FALSE(confirmation.vote(4, true));  // the count started over
  confirmation.keep_votes_of([](std::uint64_t birth) { return birth == 9; });
  EXPECT_TRUE(confirmation.vote(9, true));
  EXPECT_FALSE(confirmation.vote(4, true));  // birth 4's votes were dropped
}

TEST(DiscoveryConfirmation, SiblingsNeverSeenApartJoinTheLargerWhenOneLeaves) {
  DiscoveryConfirmation confirmation(confirm_options());
  const std::map<std::int32_t, std::vector<int>> members{{1, range(0, 10)}, {2, range(10, 20)}};
  const auto together = DiscoveryConfirmation::match({range(0, 20)}, labels());
  const auto model_size = [](std::int32_t id) { return id == 2 ? std::size_t{900} : std::size_t{400}; };
  for (int frame = 0; frame < 3; ++frame) confirmation.watch_siblings(members, together);  // 5 - 2 + 1 = 4 needed
  EXPECT_TRUE(confirmation.unparted_siblings(std::vector<std::int32_t>{3}, model_size).empty());  // not theirs
  EXPECT_EQ(confirmation.watched_pairs(), 1u);
  EXPECT_TRUE(confirmation.unparted_siblings(std::vector<std::int32_t>{1}, model_size).empty());  // 3 frames: too few
  EXPECT_EQ(confirmation.watched_pairs(), 0u);  // decided and forgotten
  for (int frame = 0; frame < 4; ++frame) confirmation.watch_siblings(members, together);
  const auto joins = confirmation.unparted_siblings(std::vector<std::int32_t>{1}, model_size);
  ASSERT_EQ(joins.size(), 1u);
  EXPECT_EQ(joins[0], std::make_pair(2, 1));  // the smaller joins the larger
}

TEST(DiscoveryConfirmation, OneFrameApartKeepsSiblingsApart) {
  DiscoveryConfirmation confirmation(confirm_options());
  const std::map<std::int32_t, std::vector<int>> members{{1, range(0, 10)}, {2, range(10, 20)}};
  const auto model_size = [](std::int32_t) { return std::size_t{400}; };
  for (int frame = 0; frame < 5; ++frame) {
    confirmation.watch_siblings(members, DiscoveryConfirmation::match({range(0, 20)}, labels()));
  }
  confirmation.watch_siblings(members, DiscoveryConfirmation::match({range(0, 10), range(10, 20)}, labels()));
  EXPECT_TRUE(confirmation.unparted_siblings(std::vector<std::int32_t>{2}, model_size).empty());
}

TEST(DiscoveryConfirmation, APieceOfThreeJoinsWhatItsSiblingJoined) {
  // Three siblings, all in one part every frame, model sizes by id: each pair is decided, and a pair whose ids
  // were joined already is skipped.
  DiscoveryConfirmation confirmation(confirm_options());
  std::vector<std::int32_t> three(30, 0);
  for (int i = 0; i < 30; ++i) three[static_cast<std::size_t>(i)] = 1 + i / 10;
  const std::map<std::int32_t, std::vector<int>> members{{1, range(0, 10)}, {2, range(10, 20)}, {3, range(20, 30)}};
  for (int frame = 0; frame < 4; ++frame) {
    confirmation.watch_siblings(members, DiscoveryConfirmation::match({range(0, 30)}, three));
  }
  const auto model_size = [](std::int32_t id) { return static_cast<std::size_t>(100 * id); };
  const auto joins = confirmation.unparted_siblings(std::vector<std::int32_t>{1, 2, 3}, model_size);
  // Pairs in order (1,2) (1,3) (2,3): 1 joins 2; then 1, now in 2, gives 2 joins 3; then 2 and 3 are one.
  ASSERT_EQ(joins.size(), 2u);
  EXPECT_EQ(joins[0], std::make_pair(2, 1));
  EXPECT_EQ(joins[1], std::make_pair(3, 2));
}

}  // namespace
}  // namespace mfot
