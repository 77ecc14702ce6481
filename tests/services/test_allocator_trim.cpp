// trim_allocator_caches (service_main): the pages a service freed between blocks it still holds go
// back to the system, so its resident memory follows what it holds now.

#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "mfot/service/service_main.hpp"

namespace mfot::service {
namespace {

// This process's resident anonymous memory, kB (/proc/self/status RssAnon); -1 when unknown.
long rss_anon_kb() {
  std::ifstream status("/proc/self/status");
  std::string key;
  long value = 0;
  std::string unit;
  while (status >> key) {
    if (key == "RssAnon:") return (status >> value) ? value : -1;
    std::getline(status, unit);
  }
  return -1;
}

TEST(AllocatorTrim, GivesBackThePagesFreedBetweenBlocksStillHeld) {
#if !defined(__GLIBC__)
  GTEST_SKIP() << "glibc's malloc_trim only";
#else
  ASSERT_GT(rss_anon_kb(), 0);
  bound_allocator_caches();  // as every service: blocks below 256 kB come from the heap
  // 16 MB of 4 kB blocks, every 64th kept: the heap's top stays in use, so only pages between the
  // blocks still held can go back (fragmentation, as a long run's objects come and go).
  constexpr std::size_t kBlocks = 4096;
  constexpr std::size_t kBytes = 4096;
  std::vector<std::unique_ptr<char[]> > blocks(kBlocks);
  for (auto& block : blocks) {
    block = std::make_unique<char[]>(kBytes);
    std::memset(block.get(), 1, kBytes);
  }
  for (std::size_t i = 0; i < kBlocks; ++i) {
    if (i % 64 != 63) blocks[i].reset();
  }
  const long before = rss_anon_kb();
  EXPECT_TRUE(trim_allocator_caches());
  const long after = rss_anon_kb();
  EXPECT_GT(before - after, 8 * 1024) << "resident anonymous memory " << before << " -> " << after << " kB";
  for (std::size_t i = 63; i < kBlocks; i += 64) EXPECT_EQ(blocks[i][kBytes - 1], 1);  // the kept ones intact
#endif
}

}  // namespace
}  // namespace mfot::service
