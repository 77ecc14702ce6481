#include "mfot/service/service_main.hpp"

#include <malloc.h>
#include <spdlog/spdlog.h>

#include "mfot/service/config.hpp"

namespace mfot::service {

void bound_allocator_caches() {
#if defined(__GLIBC__)
  // glibc raises its mmap threshold to the largest mapped block freed (up to 32 MB) and keeps up to
  // twice that free at the top of its heap: a long run's resident memory then climbs with the largest
  // buffers it ever used (a registration's JCSD grid, a big scene) and never comes back. Fixed
  // thresholds turn that off: blocks from kMmapThreshold up are mapped and returned when freed, and
  // the heap's free top is given back beyond kTrimThreshold.
  constexpr int kMmapThreshold = 256 * 1024;
  constexpr int kTrimThreshold = 1024 * 1024;
  if (mallopt(M_MMAP_THRESHOLD, kMmapThreshold) != 1 || mallopt(M_TRIM_THRESHOLD, kTrimThreshold) != 1) {
    spdlog::warn("mallopt refused the allocator thresholds: resident memory may keep freed blocks");
  }
#endif
}

bool trim_allocator_caches() {
#if defined(__GLIBC__)
  return malloc_trim(0) == 1;
#else
  return false;
#endif
}

int run_service_main(const std::function<int()>& body) {
  bound_allocator_caches();
  try {
    return body();
  } catch (const ConfigError& e) {
    spdlog::error("configuration refused: {}", e.what());
    return kExitConfigRefused;
  } catch (const OutputError& e) {
    spdlog::error("output failed: {}", e.what());
    return kExitOutputFailed;
  } catch (const std::exception& e) {
    spdlog::error("fatal: {}", e.what());
    return 1;
  }
}

}  // namespace mfot::service
