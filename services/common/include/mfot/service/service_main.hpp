#pragma once
// The common ending of every service's main: a refused configuration exits with 2, an output file
// that cannot be written (a full disk, a read-only folder: OutputError) with 3, any other failure
// with 1, each logged with its reason. scripts/mfot-run restarts none of 2 and 3 (a restart would
// fail the same way) and stops the whole group on 3.

#include <functional>
#include <stdexcept>
#include <string>

namespace mfot::service {

// Sets the allocator's fixed thresholds first (bound_allocator_caches).
inline constexpr int kExitConfigRefused = 2;
inline constexpr int kExitOutputFailed = 3;

// A file of the run's output could not be written; what() names the path and the system's reason.
class OutputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

int run_service_main(const std::function<int()>& body);

// Large blocks are mapped and returned to the system when freed, and the heap's free top is trimmed
// beyond 1 MB (glibc mallopt; nothing elsewhere): resident memory follows what a service holds now,
// not the most it ever held.
void bound_allocator_caches();

// Gives the allocator's free pages back to the system, those inside its heaps too (glibc
// malloc_trim(0); nothing elsewhere). A heap profile of a live group (heaptrack) shows no leak, but
// the pages freed between live blocks stay resident: without this a long run's resident memory keeps
// the most it ever held at once, scattered by fragmentation, instead of what it holds now. Returns
// true when memory was given back. Called once a second by every service (StatusReporter::tick).
bool trim_allocator_caches();

}  // namespace mfot::service
