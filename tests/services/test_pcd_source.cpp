// A folder of organised PCD files as a frame source: natural name order, depth and colour from the
// cloud, intrinsics fitted to it, and every kind of unusable file skipped with its name.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "mfot/capture/capture_settings.hpp"
#include "mfot/capture/pcd_source.hpp"

namespace mfot::capture {
namespace {

namespace fs = std::filesystem;

constexpr float kFx = 500.f, kFy = 510.f, kCx = 3.5f, kCy = 2.5f;
constexpr int kWidth = 8, kHeight = 6;

class PcdFolder {
 public:
  PcdFolder()
      : path_(fs::temp_directory_path() / ("mfot_pcd_" + std::to_string(::getpid()) + "_" +
                                           ::testing::UnitTest::GetInstance()->current_test_info()->name())) {
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~PcdFolder() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  PcdFolder(const PcdFolder&) = delete;
  PcdFolder& operator=(const PcdFolder&) = delete;
  std::string str() const { return path_.string(); }
  void write(const std::string& name, const std::string& text) const { std::ofstream(path_ / name) << text; }

 private:
  fs::path path_;
};

// An organised ASCII PCD of a pinhole camera (kFx, kFy, kCx, kCy) looking at a tilted plane, depth
// `base` metres at the centre; pixel (0, 0) unmeasured (NaN); colour encodes the pixel.
std::string organised_pcd(float base, int height = kHeight, bool nan_everywhere = false,
                          const std::string& colour_field = "rgba") {
  std::ostringstream out;
  out << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z " << colour_field << "\nSIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\n"
      << "WIDTH " << kWidth << "\nHEIGHT " << height << "\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << kWidth * height
      << "\nDATA ascii\n";
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      if (nan_everywhere || (u == 0 && v == 0)) {
        out << "nan nan nan 0\n";
        continue;
      }
      const float z = base + 0.01f * static_cast<float>(u) + 0.02f * static_cast<float>(v);
      const float x = (static_cast<float>(u) - kCx) * z / kFx, y = (static_cast<float>(v) - kCy) * z / kFy;
      const std::uint32_t rgba =
          (255u << 24) | (static_cast<std::uint32_t>(10 * u) << 16) | (static_cast<std::uint32_t>(20 * v) << 8) | 7u;
      out.precision(9);
      out << x << ' ' << y << ' ' << z << ' ' << rgba << '\n';
    }
  }
  return out.str();
}

TEST(PcdFolderSource, PlaysTheFilesInNaturalOrderAsRgbdFrames) {
  PcdFolder folder;
  folder.write("frame10.pcd", organised_pcd(1.0f));
  folder.write("frame2.pcd", organised_pcd(0.8f));
  folder.write("frame1.pcd", organised_pcd(0.6f));
  folder.write("notes.txt", "not a cloud");
  PcdFolderSource source(folder.str(), 0.1, 0);
  ASSERT_EQ(source.files().size(), 3u);
  EXPECT_EQ(source.kind(), "pcd");
  for (const float base : {0.6f, 0.8f, 1.0f}) {
    const auto item = source.next();
    ASSERT_TRUE(item);
    const service::Frame& f = item->frame;
    EXPECT_EQ(f.width, kWidth);
    EXPECT_EQ(f.height, kHeight);
    EXPECT_NEAR(f.fx, kFx, 0.05f);
    EXPECT_NEAR(f.fy, kFy, 0.05f);
    EXPECT_NEAR(f.cx, kCx, 0.01f);
    EXPECT_NEAR(f.cy, kCy, 0.01f);
    EXPECT_EQ(f.depth_mm[0], 0);  // the unmeasured pixel
    EXPECT_EQ(f.depth_mm[1], static_cast<std::uint16_t>(std::lround((base + 0.01f) * 1000.f)));
    EXPECT_EQ(f.color[kWidth + 3].r, 30);
    EXPECT_EQ(f.color[kWidth + 3].g, 20);
    EXPECT_EQ(f.color[kWidth + 3].b, 7);
    EXPECT_EQ(f.capture_utime, 100000 * item->index);
    EXPECT_NO_THROW(f.validate());
  }
  EXPECT_FALSE(source.next());
  ASSERT_TRUE(source.rewind());
  EXPECT_EQ(source.next()->frame.depth_mm[1], 610);
}

TEST(PcdFolderSource, SkipsEveryUnusableFileNamingItAndGoesOn) {
  PcdFolder folder;
  folder.write("a1.pcd", organised_pcd(0.7f));
  const std::string good = organised_pcd(0.9f);
  folder.write("a2.pcd", good.substr(0, good.size() / 2));  // truncated
  folder.write("a3.pcd", organised_pcd(0.9f, 1));           // unorganised (one row)
  folder.write("a4.pcd",
               "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
               "WIDTH 2\nHEIGHT 2\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 4\nDATA ascii\n"
               "0 0 1\n0 0 1\n0 0 1\n0 0 1\n");                // no colour
  folder.write("a5.pcd", organised_pcd(0.9f, kHeight, true));  // NaN everywhere
  folder.write("a6.pcd", "garbage\n");                         // not a PCD
  folder.write("a7.pcd", organised_pcd(1.1f, kHeight, false, "rgb"));
  PcdFolderSource source(folder.str(), 1.0 / 30.0, 0);
  auto item = source.next();
  ASSERT_TRUE(item);
  EXPECT_EQ(item->frame.depth_mm[1], 710);
  item = source.next();  // a2..a6 skipped
  ASSERT_TRUE(item);
  EXPECT_EQ(item->frame.depth_mm[1], 1110);
  EXPECT_EQ(item->index, 1);
  EXPECT_EQ(source.skipped_files(), 5);
  EXPECT_FALSE(source.next());
}

TEST(PcdFolderSource, AMissingOrEmptyFolderIsRefusedWithItsName) {
  PcdFolder folder;
  try {
    PcdFolderSource source(folder.str(), 0.1, 0);
    FAIL() << "an empty folder was accepted";
  } catch (const CaptureError& e) {
    EXPECT_NE(std::string(e.what()).find("no .pcd files"), std::string::npos) << e.what();
  }
  EXPECT_THROW(PcdFolderSource("/nonexistent/pcds", 0.1, 0), CaptureError);
}

TEST(PcdFolderSource, ALabelFieldIsTheGroundTruthWithTheBackgroundLabelsAsZero) {
  PcdFolder folder;
  std::ostringstream out;
  out << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z rgba label\nSIZE 4 4 4 4 4\nTYPE F F F U U\nCOUNT 1 1 1 1 1\n"
      << "WIDTH " << kWidth << "\nHEIGHT " << kHeight << "\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << kWidth * kHeight
      << "\nDATA ascii\n";
  out.precision(9);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      const float z = 0.8f + 0.01f * static_cast<float>(u + v);
      out << (static_cast<float>(u) - kCx) * z / kFx << ' ' << (static_cast<float>(v) - kCy) * z / kFy << ' ' << z
          << " 4278190080 " << (u < 4 ? 3 : 25) << '\n';  // mOSD-like: 3 a part of the table, 25 an object's
    }
  }
  folder.write("labelled.pcd", out.str());
  folder.write("plain.pcd", organised_pcd(0.8f));
  PcdFolderSource source(folder.str(), 0.1, 9);
  const auto labelled = source.next();
  ASSERT_TRUE(labelled && labelled->truth);
  const service::Image16& labels = labelled->truth->labels;
  ASSERT_EQ(labels.width, kWidth);
  ASSERT_EQ(labels.height, kHeight);
  EXPECT_EQ(labels.pixels[kWidth + 1], 0);   // the table: background
  EXPECT_EQ(labels.pixels[kWidth + 5], 25);  // the object's part keeps its label
  EXPECT_TRUE(labelled->truth->objects.empty());
  const auto plain = source.next();
  ASSERT_TRUE(plain);
  EXPECT_FALSE(plain->truth);  // no label field, no ground truth
}

TEST(PcdFolderSource, NaturalOrderComparesNumbersByValue) {
  EXPECT_TRUE(natural_less("learn2.pcd", "learn10.pcd"));
  EXPECT_FALSE(natural_less("learn10.pcd", "learn2.pcd"));
  EXPECT_TRUE(natural_less("a.pcd", "b.pcd"));
  EXPECT_TRUE(natural_less("f007.pcd", "f8.pcd"));
  EXPECT_FALSE(natural_less("f1.pcd", "f1.pcd"));
}

TEST(PcdFolderSource, IsTheSourceOfCapturePcd) {
  PcdFolder folder;
  folder.write("0.pcd", organised_pcd(0.75f));
  CaptureSettings settings;
  settings.source = "pcd";
  EXPECT_THROW(settings.validate(), service::ConfigError);  // needs capture.folder
  settings.tum_folder = folder.str();
  auto source = make_source(settings, [] { return false; });
  EXPECT_EQ(source->kind(), "pcd");
  EXPECT_TRUE(source->next());
}

}  // namespace
}  // namespace mfot::capture
