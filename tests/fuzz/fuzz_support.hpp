#pragma once
// Helpers shared by the fuzz targets: silenced logging, a private scratch folder, file writing and
// a check that aborts (so libFuzzer and the corpus driver both report it as a crash).

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>

namespace mfot::fuzz {

// Violated invariants abort with the message: an exception could be swallowed by a caller.
[[noreturn]] inline void fail(const char* what) {
  std::fprintf(stderr, "fuzz invariant violated: %s\n", what);
  std::abort();
}
#define MFOT_FUZZ_CHECK(condition)                    \
  do {                                                \
    if (!(condition)) ::mfot::fuzz::fail(#condition); \
  } while (false)

// Warnings about garbage input are expected by the thousand; they would only slow the fuzzer.
inline void silence_logging() {
  static const bool silenced = [] {
    spdlog::set_level(spdlog::level::off);
    return true;
  }();
  (void)silenced;
}

inline void remove_scratch_folder();

// A folder owned by this process (in /dev/shm when available: targets rewrite files per input),
// removed at exit.
inline const std::filesystem::path& scratch_folder() {
  static const std::filesystem::path folder = [] {
    std::error_code error;
    const std::filesystem::path base = std::filesystem::is_directory("/dev/shm", error)
                                           ? std::filesystem::path("/dev/shm")
                                           : std::filesystem::temp_directory_path();
    auto path = base / ("mfot-fuzz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(path);
    return path;
  }();
  // Registered after `folder` is complete, so it runs before `folder` is destroyed.
  static const bool cleanup_registered = std::atexit(remove_scratch_folder) == 0;
  (void)cleanup_registered;
  return folder;
}

inline void remove_scratch_folder() {
  std::error_code ignored;
  std::filesystem::remove_all(scratch_folder(), ignored);
}

inline void write_file(const std::filesystem::path& path, const void* data, std::size_t size) {
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (file == nullptr) fail("cannot create a scratch file");
  const bool ok = size == 0 || std::fwrite(data, 1, size, file) == size;
  if (std::fclose(file) != 0 || !ok) fail("cannot write a scratch file");
}

inline void write_file(const std::filesystem::path& path, const std::string& text) {
  write_file(path, text.data(), text.size());
}

}  // namespace mfot::fuzz
