#include <gtest/gtest.h>

#include <future>
#include <stdexcept>
#include <vector>

#include "mfot/service/background_queue.hpp"

namespace mfot::service {
namespace {

TEST(BackgroundQueue, RunsJobsInOrderAndFinishWaitsForThem) {
  std::vector<int> done;  // written by the worker only; read after finish()
  BackgroundQueue queue("test", 2, 5);
  for (int i = 0; i < 50; ++i) queue.push([&done, i] { done.push_back(i); });
  queue.finish();
  ASSERT_EQ(done.size(), 50u);
  for (int i = 0; i < 50; ++i) EXPECT_EQ(done[static_cast<std::size_t>(i)], i);
}

TEST(BackgroundQueue, PushBlocksWhileTheBacklogIsFull) {
  std::promise<void> release;
  std::shared_future<void> released = release.get_future().share();
  std::promise<void> started;
  BackgroundQueue queue("test", 1, 0);
  queue.push([&started, released] {
    started.set_value();
    released.wait();
  });
  started.get_future().wait();  // the first job runs and holds the worker
  queue.push([] {});            // fills the backlog of one
  auto third = std::async(std::launch::async, [&queue] { queue.push([] {}); });
  // The third push cannot return before the first job is released.
  EXPECT_EQ(third.wait_for(std::chrono::seconds(0)), std::future_status::timeout);
  release.set_value();
  third.get();
  queue.finish();
}

TEST(BackgroundQueue, AJobsExceptionReachesTheCaller) {
  BackgroundQueue queue("test", 4, 0);
  queue.push([] { throw std::runtime_error("disk full"); });
  try {
    queue.finish();
    ADD_FAILURE() << "finish() did not rethrow";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "disk full");
  }
  // Reported once; the queue goes on.
  bool ran = false;
  queue.push([&ran] { ran = true; });
  queue.finish();
  EXPECT_TRUE(ran);
}

TEST(BackgroundQueue, DestructorFinishesQueuedJobs) {
  int done = 0;
  {
    BackgroundQueue queue("test", 8, 0);
    for (int i = 0; i < 8; ++i) queue.push([&done] { ++done; });
  }
  EXPECT_EQ(done, 8);
}

TEST(BackgroundQueue, RefusesBadSettings) {
  EXPECT_THROW(BackgroundQueue("test", 0, 0), std::invalid_argument);
  EXPECT_THROW(BackgroundQueue("test", 2000, 0), std::invalid_argument);
  EXPECT_THROW(BackgroundQueue("test", 1, -1), std::invalid_argument);
  EXPECT_THROW(BackgroundQueue("test", 1, 20), std::invalid_argument);
}

}  // namespace
}  // namespace mfot::service
