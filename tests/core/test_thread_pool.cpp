#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "mfot/thread_pool.hpp"

namespace mfot {
namespace {

TEST(ThreadPool, RunsEveryTaskOnceForAnyThreadCount) {
  for (const int threads : {1, 2, 5}) {
    ThreadPool pool(threads);
    EXPECT_EQ(pool.threads(), threads);
    for (const std::size_t count : {std::size_t{0}, std::size_t{1}, std::size_t{3}, std::size_t{100}}) {
      std::vector<int> runs(count, 0);  // each task writes its own entry
      pool.run(count, [&runs](std::size_t i) { ++runs[i]; });
      EXPECT_EQ(runs, std::vector<int>(count, 1)) << threads << " threads, " << count << " tasks";
    }
  }
}

TEST(ThreadPool, RethrowsTheExceptionOfTheLowestFailingTask) {
  for (const int threads : {1, 3}) {
    ThreadPool pool(threads);
    try {
      pool.run(50, [](std::size_t i) {
        if (i % 7 == 3) throw std::runtime_error("task " + std::to_string(i));
      });
      FAIL() << "no exception";
    } catch (const std::runtime_error& e) {
      EXPECT_STREQ(e.what(), "task 3");
    }
    // The pool stays usable.
    std::vector<int> runs(10, 0);
    pool.run(runs.size(), [&runs](std::size_t i) { runs[i] = static_cast<int>(i); });
    EXPECT_EQ(runs[9], 9);
  }
}

TEST(ThreadPool, ThreadCountIsValidated) {
  EXPECT_THROW(ThreadPool(0), std::invalid_argument);
  EXPECT_THROW(ThreadPool(65), std::invalid_argument);
}

}  // namespace
}  // namespace mfot
