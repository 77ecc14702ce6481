// RunWriter on a full disk: every file it cannot write is an OutputError naming the path and the
// system's reason, never a silent loss. /dev/full (every write fails with ENOSPC) stands in for the
// disk: the files are symbolic links to it.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "mfot/service/run_writer.hpp"
#include "mfot/service/service_main.hpp"

namespace mfot::service {
namespace {

namespace fs = std::filesystem;

class RunDir {
 public:
  RunDir()
      : path_(fs::temp_directory_path() / ("mfot_run_writer_" + std::to_string(::getpid()) + "_" +
                                           testing::UnitTest::GetInstance()->current_test_info()->name())) {
    fs::remove_all(path_);
    fs::create_directories(path_ / "labels");
  }
  ~RunDir() {
    std::error_code error;
    fs::remove_all(path_, error);
  }
  RunDir(const RunDir&) = delete;
  RunDir& operator=(const RunDir&) = delete;
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

std::string output_error(const std::function<void()>& body) {
  try {
    body();
  } catch (const OutputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no OutputError";
  return {};
}

bool have_dev_full() { return fs::exists("/dev/full"); }

TEST(RunWriterErrors, AFullDiskUnderPosesCsvNamesTheFileAndTheReason) {
  if (!have_dev_full()) GTEST_SKIP() << "/dev/full is missing";
  RunDir dir;
  fs::create_symlink("/dev/full", dir.path() / "poses.csv");
  RunWriter writer(dir.path().string());
  Pose pose;
  writer.write_pose(0, 1000, 1, pose, 1.f, false);
  const std::string what = output_error([&] { writer.flush_poses(); });
  EXPECT_NE(what.find((dir.path() / "poses.csv").string()), std::string::npos) << what;
  EXPECT_NE(what.find("No space left on device"), std::string::npos) << what;
}

TEST(RunWriterErrors, AFullDiskUnderALabelImageNamesTheFileAndTheReason) {
  if (!have_dev_full()) GTEST_SKIP() << "/dev/full is missing";
  RunDir dir;
  const fs::path temporary = dir.path() / "labels" / "000007.png.tmp";
  fs::create_symlink("/dev/full", temporary);
  RunWriter writer(dir.path().string());
  Image16 labels;
  labels.width = 64;
  labels.height = 48;
  labels.pixels.assign(64 * 48, 3);
  const std::string what = output_error([&] { writer.write_labels(7, labels); });
  EXPECT_NE(what.find(temporary.string()), std::string::npos) << what;
  EXPECT_NE(what.find("No space left on device"), std::string::npos) << what;
  EXPECT_FALSE(fs::exists(dir.path() / "labels" / "000007.png"));  // nothing half-written in place
  // A later frame on a disk with room is written as usual.
  writer.write_labels(8, labels);
  EXPECT_TRUE(fs::exists(dir.path() / "labels" / "000008.png"));
}

TEST(RunWriterErrors, AFolderThatCannotBeCreatedIsNamed) {
  const std::string what = output_error([] { RunWriter writer("/dev/null/run"); });
  EXPECT_NE(what.find("/dev/null/run"), std::string::npos) << what;
  EXPECT_NE(what.find("cannot create run directory"), std::string::npos) << what;
}

}  // namespace
}  // namespace mfot::service
