#include <gtest/gtest.h>

#include <chrono>
#include <stdexcept>

#include "mfot/service/tracker_scene_queue.hpp"

namespace mfot::service {
namespace {

using namespace std::chrono_literals;
using Clock = TrackerSceneQueue::Clock;

Scene scene(std::int64_t seq) {
  Scene s;
  s.frame_seq = seq;
  return s;
}

// The frame of the next released scene, or -1 when none is released at `now`.
std::int64_t next_seq(TrackerSceneQueue& queue, Clock::time_point now = Clock::time_point{}) {
  const auto s = queue.next(now);
  return s ? s->frame_seq : -1;
}

TEST(TrackerSceneQueue, ReleasesEachSceneOnlyWithTheModelOfTheFrameBefore) {
  TrackerSceneQueue queue;
  queue.model_received(7, 0);  // object 7 created when frame 0 was finished
  for (int seq = 1; seq <= 3; ++seq) EXPECT_EQ(queue.add_scene(scene(seq)), TrackerSceneQueue::Arrival::kQueued);
  EXPECT_EQ(next_seq(queue), 1);
  EXPECT_EQ(queue.last_done(), 1);
  EXPECT_EQ(next_seq(queue), -1) << "scene 2 needs the model of frame 1";
  queue.frame_finished(1);  // another object's model of frame 1 came first
  EXPECT_EQ(next_seq(queue), -1) << "this object's model of frame 1 is still on its way";
  queue.model_received(7, 1);
  EXPECT_EQ(next_seq(queue), 2);
  EXPECT_EQ(next_seq(queue), -1);
  queue.model_received(7, 2);
  EXPECT_EQ(next_seq(queue), 3);
  EXPECT_EQ(queue.size(), 0u);
  EXPECT_EQ(queue.fallbacks(), 0);
}

TEST(TrackerSceneQueue, AnIdleWorkerKeepsScenesAndTracksTheOpenOnesWhenAssigned) {
  TrackerSceneQueue queue;
  for (int seq = 3; seq <= 6; ++seq) queue.add_scene(scene(seq));
  EXPECT_EQ(next_seq(queue), -1) << "no object: nothing to track";
  queue.frame_finished(3);  // the merger finished frame 3
  EXPECT_EQ(queue.size(), 3u);
  queue.model_received(2, 4);  // assigned object 2 after frame 4
  EXPECT_EQ(queue.size(), 2u) << "frame 4 is finished: not this worker's to track";
  EXPECT_EQ(queue.last_done(), 4);
  EXPECT_EQ(next_seq(queue), 5);
  EXPECT_EQ(next_seq(queue), -1);
}

TEST(TrackerSceneQueue, RefusesLateRepeatedAndFinishedScenesAndSortsReorderedOnes) {
  TrackerSceneQueue queue;
  queue.model_received(1, 4);
  EXPECT_EQ(queue.add_scene(scene(4)), TrackerSceneQueue::Arrival::kRefused) << "finished";
  EXPECT_EQ(queue.add_scene(scene(7)), TrackerSceneQueue::Arrival::kQueued);
  EXPECT_EQ(queue.add_scene(scene(5)), TrackerSceneQueue::Arrival::kQueued) << "reordered: joins in order";
  EXPECT_EQ(queue.add_scene(scene(7)), TrackerSceneQueue::Arrival::kRefused) << "a re-sent scene already queued";
  EXPECT_EQ(next_seq(queue), 5);
  EXPECT_EQ(queue.add_scene(scene(5)), TrackerSceneQueue::Arrival::kRefused) << "tracked already";
  EXPECT_EQ(queue.size(), 1u);
}

TEST(TrackerSceneQueue, RefusesOlderAndRepeatedModelsOfTheHeldObject) {
  TrackerSceneQueue queue;
  EXPECT_TRUE(queue.accepts_model(3, 10));
  queue.model_received(3, 10);
  EXPECT_FALSE(queue.accepts_model(3, 10)) << "a repeat (the merger's re-send)";
  EXPECT_FALSE(queue.accepts_model(3, 9)) << "a reordered older model";
  EXPECT_TRUE(queue.accepts_model(3, 11));
  EXPECT_TRUE(queue.accepts_model(4, 10)) << "another object: a new assignment";
  queue.object_dropped();
  EXPECT_TRUE(queue.accepts_model(3, 10)) << "after a retirement the id may come back";
}

TEST(TrackerSceneQueue, AMissingSceneIsWaitedForAWhileThenPassed) {
  TrackerSceneQueueOptions options;
  options.gap_wait = 200ms;
  TrackerSceneQueue queue(options);
  const auto t0 = Clock::time_point{} + 10s;
  queue.model_received(1, 0);
  queue.add_scene(scene(1));
  queue.add_scene(scene(3));  // scene 2 was lost on the way to this worker
  EXPECT_EQ(next_seq(queue, t0), 1);
  queue.model_received(1, 1);
  EXPECT_EQ(next_seq(queue, t0), -1) << "the merger sends scene 2 again";
  queue.add_scene(scene(2));
  EXPECT_EQ(next_seq(queue, t0 + 100ms), 2);
  queue.model_received(1, 2);
  EXPECT_EQ(next_seq(queue, t0 + 100ms), 3);
  EXPECT_EQ(queue.gaps_passed(), 0);

  // A frame nobody got (preprocessing dropped it): after gap_wait the next one goes ahead.
  queue.add_scene(scene(5));
  queue.model_received(1, 3);
  EXPECT_EQ(next_seq(queue, t0 + 1s), -1);
  EXPECT_EQ(next_seq(queue, t0 + 1s + 199ms), -1);
  EXPECT_EQ(next_seq(queue, t0 + 1s + 200ms), 5);
  EXPECT_EQ(queue.gaps_passed(), 1);
  EXPECT_EQ(queue.fallbacks(), 0);
}

TEST(TrackerSceneQueue, AFrameTheMergerFinishedIsNoGap) {
  // The merger finished frame 2 without this worker (its scene never reached it): scene 3 needs
  // the model of frame 2, not scene 2.
  TrackerSceneQueue queue;
  queue.model_received(1, 0);
  queue.add_scene(scene(1));
  queue.add_scene(scene(3));
  EXPECT_EQ(next_seq(queue), 1);
  queue.model_received(1, 1);
  queue.frame_finished(2);
  EXPECT_EQ(next_seq(queue), -1);
  queue.model_received(1, 2);
  EXPECT_EQ(next_seq(queue), 3);
  EXPECT_EQ(queue.gaps_passed(), 0);
}

TEST(TrackerSceneQueue, DropsTheOldestSceneBeyondItsSizeAndSaysItSkippedIt) {
  TrackerSceneQueueOptions options;
  options.max_scenes = 2;
  TrackerSceneQueue queue(options);
  queue.add_scene(scene(1));
  queue.add_scene(scene(2));
  queue.add_scene(scene(3));
  EXPECT_EQ(queue.skipped(), 0) << "idle: no estimate is owed";
  queue.model_received(5, 0);
  queue.add_scene(scene(4));
  EXPECT_EQ(queue.size(), 2u);
  EXPECT_EQ(queue.skipped(), 1);
  EXPECT_EQ(queue.last_done(), 2) << "frame 2 will get no estimate from this worker";
  EXPECT_EQ(next_seq(queue), -1) << "scene 3 waits for the merger's model of frame 2";
  queue.model_received(5, 2);
  EXPECT_EQ(next_seq(queue), 3);
}

TEST(TrackerSceneQueue, AFarOlderSceneStartsANewSequenceTrackedWithTheHeldModel) {
  TrackerSceneQueue queue;
  queue.model_received(1, 499);
  queue.add_scene(scene(500));
  EXPECT_EQ(next_seq(queue), 500);
  EXPECT_EQ(queue.add_scene(scene(0)), TrackerSceneQueue::Arrival::kNewSequence);
  EXPECT_EQ(queue.last_done(), -1);
  EXPECT_EQ(next_seq(queue), 0) << "the first frame of the new sequence uses the model held";
  queue.add_scene(scene(1));
  EXPECT_FALSE(queue.accepts_model(1, 500)) << "a late model of the old sequence";
  queue.frame_finished(500);
  EXPECT_EQ(queue.size(), 1u) << "nor does it finish the new sequence's frames";
  EXPECT_EQ(next_seq(queue), -1);
  EXPECT_TRUE(queue.accepts_model(1, 0));
  queue.model_received(1, 0);
  EXPECT_EQ(next_seq(queue), 1);
}

TEST(TrackerSceneQueue, AModelThatNeverComesIsGivenUpAfterTheWait) {
  TrackerSceneQueueOptions options;
  options.model_wait = 300ms;
  TrackerSceneQueue queue(options);
  queue.model_received(1, 0);
  queue.add_scene(scene(1));
  queue.add_scene(scene(2));
  const auto t0 = Clock::time_point{} + 10s;
  EXPECT_EQ(next_seq(queue, t0), 1);
  EXPECT_EQ(next_seq(queue, t0), -1);
  EXPECT_EQ(next_seq(queue, t0 + 299ms), -1);
  EXPECT_EQ(next_seq(queue, t0 + 300ms), 2);
  EXPECT_EQ(queue.fallbacks(), 1);
}

TEST(TrackerSceneQueue, ARetiredObjectsScenesWaitForTheNextObject) {
  TrackerSceneQueue queue;
  queue.model_received(1, 10);
  queue.add_scene(scene(11));
  queue.add_scene(scene(12));
  EXPECT_EQ(next_seq(queue), 11);
  // Object 1 retired when frame 11 was finished: no model of frame 11 comes for it.
  queue.frame_finished(11);
  queue.object_dropped();
  EXPECT_EQ(next_seq(queue, Clock::time_point{} + 1h), -1);
  queue.model_received(2, 11);  // a new object for this worker at the same frame
  EXPECT_EQ(next_seq(queue), 12);
}

TEST(TrackerSceneQueue, ValidatesItsOptions) {
  TrackerSceneQueueOptions options;
  options.max_scenes = 0;
  EXPECT_THROW(TrackerSceneQueue{options}, std::invalid_argument);
  options.max_scenes = 65;
  EXPECT_THROW(TrackerSceneQueue{options}, std::invalid_argument);
  options.max_scenes = 8;
  options.model_wait = 0ms;
  EXPECT_THROW(TrackerSceneQueue{options}, std::invalid_argument);
  options.model_wait = 100ms;
  options.gap_wait = -1ms;
  EXPECT_THROW(TrackerSceneQueue{options}, std::invalid_argument);
}

}  // namespace
}  // namespace mfot::service
