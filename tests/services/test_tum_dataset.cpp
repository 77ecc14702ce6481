#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "mfot/service/tum_dataset.hpp"

namespace mfot::service {
namespace {
namespace fs = std::filesystem;

class TempFolder {
 public:
  TempFolder() {
    const auto* info = testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() /
            ("mfot_" + std::string(info->test_suite_name()) + "_" + info->name() + "_" + std::to_string(::getpid()));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  TempFolder(const TempFolder&) = delete;
  TempFolder& operator=(const TempFolder&) = delete;
  ~TempFolder() {
    std::error_code error;
    fs::remove_all(path_, error);
  }
  std::string str(const std::string& child = "") const {
    return child.empty() ? path_.string() : (path_ / child).string();
  }

 private:
  fs::path path_;
};

Frame make_frame(int k, int width = 24, int height = 16) {
  Frame frame;
  frame.capture_utime = 1305031102175304 + k * 33333;
  frame.width = width;
  frame.height = height;
  frame.fx = 570.5f;
  frame.fy = 571.25f;
  frame.cx = 11.5f;
  frame.cy = 7.75f;
  for (int i = 0; i < width * height; ++i) {
    frame.depth_mm.push_back(static_cast<std::uint16_t>(i % 9 == 0 ? 0 : 400 + 13 * i + 5 * k));
    frame.color.push_back(Rgb8{static_cast<std::uint8_t>(i * 7 + k), static_cast<std::uint8_t>(i * 3),
                               static_cast<std::uint8_t>(255 - i % 256)});
  }
  return frame;
}

GroundTruthFrame make_truth(int k, const Frame& frame) {
  GroundTruthFrame truth;
  truth.frame = k;
  truth.utime = frame.capture_utime;
  GroundTruthObject box;
  box.id = 1;
  box.pose.translation = Eigen::Vector3f(0.1f * static_cast<float>(k), -0.05f, 0.9f);
  box.pose.rotation = Eigen::Quaternionf(Eigen::AngleAxisf(0.3f * static_cast<float>(k), Eigen::Vector3f::UnitZ()));
  box.symmetry_axis = Eigen::Vector3f::UnitZ();  // a can
  GroundTruthObject hand;
  hand.id = 101;
  hand.is_hand = true;
  hand.pose.translation = Eigen::Vector3f(0.2f, 0.1f, 1.1f);
  truth.objects = {box, hand};
  truth.labels = Image16{frame.width, frame.height, std::vector<std::uint16_t>(frame.depth_mm.size(), 0)};
  for (std::size_t i = 0; i < truth.labels.pixels.size(); i += 3) truth.labels.pixels[i] = i % 2 ? 1 : 101;
  return truth;
}

void write_dataset(const std::string& folder, int frames, TumWriterOptions options = {}) {
  options.folder = folder;
  TumDatasetWriter writer(options);
  for (int k = 0; k < frames; ++k) {
    const Frame frame = make_frame(k);
    const GroundTruthFrame truth = make_truth(k, frame);
    writer.write(frame, &truth);
  }
  EXPECT_EQ(writer.frames_written(), static_cast<std::size_t>(frames));
}

TumReaderOptions reader_options(const std::string& folder) {
  TumReaderOptions options;
  options.folder = folder;
  return options;
}

TumWriterOptions writer_options(const std::string& folder) {
  TumWriterOptions options;
  options.folder = folder;
  return options;
}

bool contains(const std::vector<std::string>& messages, const std::string& text) {
  for (const auto& m : messages) {
    if (m.find(text) != std::string::npos) return true;
  }
  return false;
}

void append_line(const std::string& path, const std::string& line) {
  std::ofstream out(path, std::ios::app);
  out << line << "\n";
}

TEST(TumDataset, WrittenFolderReadsBackIdentically) {
  TempFolder temp;
  write_dataset(temp.str("seq"), 3);
  TumDatasetReader reader(reader_options(temp.str("seq")));
  ASSERT_EQ(reader.size(), 3u);
  EXPECT_TRUE(reader.warnings().empty());
  for (int k = 0; k < 3; ++k) {
    const Frame expected = make_frame(k);
    const auto frame = reader.read(static_cast<std::size_t>(k));
    ASSERT_TRUE(frame.has_value());
    EXPECT_EQ(frame->capture_utime, expected.capture_utime);
    EXPECT_EQ(frame->width, expected.width);
    EXPECT_EQ(frame->height, expected.height);
    EXPECT_EQ(frame->fx, expected.fx);
    EXPECT_EQ(frame->fy, expected.fy);
    EXPECT_EQ(frame->cx, expected.cx);
    EXPECT_EQ(frame->cy, expected.cy);
    EXPECT_EQ(frame->depth_mm, expected.depth_mm);
    EXPECT_EQ(frame->color, expected.color);
  }
  // Every temporary file was renamed into place.
  for (const auto& item : fs::recursive_directory_iterator(temp.str("seq"))) {
    EXPECT_NE(item.path().extension(), ".tmp") << item.path();
  }
}

TEST(TumDataset, DepthScaleIsApplied) {
  TempFolder temp;
  TumWriterOptions options;
  options.depth_scale = 1000.0;
  write_dataset(temp.str("seq"), 1, options);
  // Read with the writer's scale: exact; with the TUM default (5000/m): five times shorter.
  TumReaderOptions same = reader_options(temp.str("seq"));
  same.depth_scale = 1000.0;
  EXPECT_EQ(TumDatasetReader(same).read(0)->depth_mm, make_frame(0).depth_mm);
  const auto tum = TumDatasetReader(reader_options(temp.str("seq"))).read(0);
  ASSERT_TRUE(tum.has_value());
  const auto& original = make_frame(0).depth_mm;
  for (std::size_t i = 0; i < original.size(); ++i) {
    EXPECT_EQ(tum->depth_mm[i], static_cast<std::uint16_t>(std::llround(original[i] / 5.0)));
  }
  // Depth of 13.2 m does not fit the TUM scale's 16 bits and is written as "no measurement".
  TumDatasetWriter writer(writer_options(temp.str("far")));
  Frame far = make_frame(0);
  far.depth_mm[0] = 13200;
  writer.write(far);
  EXPECT_EQ(writer.depth_pixels_clipped(), 1u);
  EXPECT_EQ(TumDatasetReader(reader_options(temp.str("far"))).read(0)->depth_mm[0], 0);
}

TEST(TumDataset, GroundTruthReadsBack) {
  TempFolder temp;
  write_dataset(temp.str("seq"), 2);
  GroundTruthReader reader(temp.str("seq/groundtruth"));
  EXPECT_TRUE(reader.warnings().empty());
  ASSERT_EQ(reader.frames().size(), 2u);
  for (int k = 0; k < 2; ++k) {
    const GroundTruthFrame expected = make_truth(k, make_frame(k));
    const GroundTruthFrame& got = reader.frames().at(k);
    EXPECT_EQ(got.utime, expected.utime);
    ASSERT_EQ(got.objects.size(), 2u);
    for (std::size_t o = 0; o < 2; ++o) {
      EXPECT_EQ(got.objects[o].id, expected.objects[o].id);
      EXPECT_EQ(got.objects[o].is_hand, expected.objects[o].is_hand);
      EXPECT_TRUE(got.objects[o].pose.translation.isApprox(expected.objects[o].pose.translation, 1e-6f));
      EXPECT_NEAR(got.objects[o].pose.rotation.angularDistance(expected.objects[o].pose.rotation), 0.0f, 1e-5f);
      EXPECT_EQ(got.objects[o].symmetry_axis, expected.objects[o].symmetry_axis);
    }
    const auto labels = reader.labels(k);
    ASSERT_TRUE(labels.has_value());
    EXPECT_EQ(labels->pixels, expected.labels.pixels);
  }
  EXPECT_FALSE(reader.labels(7).has_value());
  EXPECT_TRUE(contains(reader.warnings(), "000007.png"));
}

TEST(TumDataset, GarbageLinesAreSkippedWithFileAndLine) {
  TempFolder temp;
  write_dataset(temp.str("seq"), 2);
  // rgb.txt: two comment lines, two frames, then line 5 and 6 are garbage.
  append_line(temp.str("seq/rgb.txt"), "this is not a timestamp");
  append_line(temp.str("seq/rgb.txt"), "1.5 rgb/a.png extra");
  append_line(temp.str("seq/depth.txt"), "nan depth/x.png");
  append_line(temp.str("seq/groundtruth/poses.csv"), "0,1,2,3");
  append_line(temp.str("seq/groundtruth/poses.csv"), "2,1,1,0,0,0,1,0,0,0,1,0,0,2");  // an axis of length 2
  TumDatasetReader reader(reader_options(temp.str("seq")));
  EXPECT_EQ(reader.size(), 2u);
  EXPECT_TRUE(contains(reader.warnings(), "rgb.txt:5:"));
  EXPECT_TRUE(contains(reader.warnings(), "rgb.txt:6:"));
  EXPECT_TRUE(contains(reader.warnings(), "depth.txt:5:"));
  GroundTruthReader truth(temp.str("seq/groundtruth"));
  EXPECT_EQ(truth.frames().size(), 2u);
  // header + 2 frames x 2 objects, then the garbage lines.
  EXPECT_TRUE(contains(truth.warnings(), "poses.csv:6:"));
  EXPECT_TRUE(contains(truth.warnings(), "poses.csv:7:"));
}

TEST(TumDataset, MissingOrEmptyFolderIsAClearError) {
  TempFolder temp;
  const auto message = [](const std::string& folder) -> std::string {
    try {
      TumDatasetReader reader(reader_options(folder));
    } catch (const DatasetError& e) {
      return e.what();
    }
    return "<no DatasetError>";
  };
  EXPECT_NE(message(temp.str("absent")).find("absent: no such folder"), std::string::npos);
  EXPECT_NE(message(temp.str()).find("rgb.txt: missing"), std::string::npos);
  std::ofstream(temp.str("rgb.txt")) << "# only a comment\n";
  std::ofstream(temp.str("depth.txt")) << "1.0 depth/1.png\n";
  EXPECT_NE(message(temp.str()).find("rgb.txt: lists no images"), std::string::npos);
  std::ofstream(temp.str("rgb.txt")) << "5.0 rgb/5.png\n";
  EXPECT_NE(message(temp.str()).find("no rgb/depth pair"), std::string::npos);
  EXPECT_THROW(GroundTruthReader(temp.str("absent")), DatasetError);
}

TEST(TumDataset, UnreadableImagesSkipTheFrameNamingTheFile) {
  TempFolder temp;
  write_dataset(temp.str("seq"), 3);
  TumDatasetReader reader(reader_options(temp.str("seq")));
  ASSERT_EQ(reader.size(), 3u);
  fs::remove(reader.entry(0).rgb_path);
  std::ofstream(reader.entry(1).depth_path, std::ios::trunc) << "not a png";
  // Frame 2: depth of the wrong size.
  write_png16(reader.entry(2).depth_path, Image16{4, 4, std::vector<std::uint16_t>(16, 1000)});

  EXPECT_FALSE(reader.read(0).has_value());
  EXPECT_TRUE(contains(reader.warnings(), reader.entry(0).rgb_path));
  EXPECT_FALSE(reader.read(1).has_value());
  EXPECT_TRUE(contains(reader.warnings(), reader.entry(1).depth_path));
  EXPECT_FALSE(reader.read(2).has_value());
  EXPECT_TRUE(contains(reader.warnings(), "depth is 4x4 but colour"));
}

TEST(TumDataset, TruncatedPngIsReportedWithItsPath) {
  TempFolder temp;
  write_dataset(temp.str("seq"), 1);
  TumDatasetReader reader(reader_options(temp.str("seq")));
  const std::string path = reader.entry(0).rgb_path;
  fs::resize_file(path, fs::file_size(path) / 2);
  try {
    read_png_rgb(path);
    ADD_FAILURE() << "truncated PNG accepted";
  } catch (const ImageIoError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(path + ": ", 0), 0u) << e.what();
  }
}

TEST(TumDataset, IntrinsicsComeFromFileOptionsOrTumDefaults) {
  TempFolder temp;
  write_dataset(temp.str("seq"), 1);
  TumReaderOptions options = reader_options(temp.str("seq"));
  options.intrinsics = std::array<float, 4>{500.0f, 501.0f, 10.0f, 8.0f};
  const auto from_file = TumDatasetReader(options).read(0);  // the folder's intrinsics.txt wins
  const auto file_only = TumDatasetReader(reader_options(temp.str("seq"))).read(0);
  EXPECT_EQ(from_file->fx, file_only->fx);
  EXPECT_NE(from_file->fx, 500.0f);
  fs::remove(temp.str("seq/intrinsics.txt"));
  const auto configured = TumDatasetReader(options).read(0);  // without it, the configured ones
  EXPECT_EQ(configured->fx, 500.0f);
  EXPECT_EQ(configured->cy, 8.0f);
  const auto defaults = TumDatasetReader(reader_options(temp.str("seq"))).read(0);
  EXPECT_EQ(defaults->fx, kTumDefaultFx);
  EXPECT_EQ(defaults->cx, kTumDefaultCx);
  std::ofstream(temp.str("seq/intrinsics.txt")) << "# fx fy cx cy\n1 2 3\n";
  EXPECT_THROW(TumDatasetReader(reader_options(temp.str("seq"))), DatasetError);
}

TEST(TumDataset, WriterRefusesExistingDatasetsAndNonIncreasingTime) {
  TempFolder temp;
  write_dataset(temp.str("seq"), 1);
  EXPECT_THROW(TumDatasetWriter(writer_options(temp.str("seq"))), DatasetError);
  TumDatasetWriter writer(writer_options(temp.str("other")));
  writer.write(make_frame(1));
  EXPECT_THROW(writer.write(make_frame(1)), DatasetError);
  EXPECT_THROW(writer.write(make_frame(0)), DatasetError);
  EXPECT_THROW(TumDatasetWriter(writer_options("")), std::invalid_argument);
}

TEST(TumAssociation, PairsNearestTimesWithinTolerance) {
  // Unsorted input; rgb 0.5 has no depth within 0.02 s; depth 0.2 is unused.
  const std::vector<double> rgb = {0.066, 0.0, 0.5, 0.033};
  const std::vector<double> depth = {0.2, 0.001, 0.07, 0.030};
  const auto pairs = associate_by_time(rgb, depth, 0.02);
  const std::vector<std::pair<std::size_t, std::size_t>> expected = {{1, 1}, {3, 3}, {0, 2}};
  EXPECT_EQ(pairs, expected);
}

TEST(TumAssociation, EachDepthIsUsedOnceByTheClosestRgb) {
  const auto pairs = associate_by_time({0.0, 0.01}, {0.006}, 0.02);
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs[0], (std::pair<std::size_t, std::size_t>{1, 0}));
  EXPECT_TRUE(associate_by_time({0.0}, {0.03}, 0.02).empty());
}

}  // namespace
}  // namespace mfot::service
