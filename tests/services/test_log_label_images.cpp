// LogLabelImages: the label images drawn from a recorded log are dense_labels of the frame, scene and
// segmentation with one sequence number, whatever order the log holds them in; the first segmentation
// of a frame wins; segmentations without their frame or scene, or with the wrong label count, are
// counted; another group's messages are not drawn.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>

#include "mfot/service/convert.hpp"
#include "mfot/service/frame_codec.hpp"
#include "mfot/service/image_io.hpp"
#include "mfot/service/log_label_images.hpp"
#include "mfot/service/merger_messages.hpp"
#include "mfot/service/message_authenticator.hpp"
#include "mfot/service/run_writer.hpp"
#include "mfot/service/service_main.hpp"

namespace mfot::service {
namespace {

namespace fs = std::filesystem;

constexpr int kWidth = 16, kHeight = 12;
constexpr float kF = 20.f, kCx = 8.f, kCy = 6.f, kLeaf = 0.01f;

// A table at 0.5 m with a box at 0.4 m over columns 4..9; `shift` moves the box by columns.
Frame test_frame(int shift) {
  Frame f;
  f.width = kWidth;
  f.height = kHeight;
  f.fx = f.fy = kF;
  f.cx = kCx;
  f.cy = kCy;
  f.depth_mm.assign(kWidth * kHeight, 500);
  f.color.assign(kWidth * kHeight, Rgb8{90, 90, 90});
  for (int v = 2; v < 9; ++v) {
    for (int u = 4 + shift; u < 10 + shift; ++u) f.depth_mm[v * kWidth + u] = 400;
  }
  return f;
}

// The box's pixels back-projected: one scene point per pixel (voxels of 1 cm hold one or two).
SceneCloud test_scene(const Frame& f) {
  SceneCloud s;
  s.voxel_grid.leaf = kLeaf;
  s.voxel_grid.corner = Eigen::Vector3f(-1.f, -1.f, 0.f);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      const float z = 0.001f * static_cast<float>(f.depth_mm[v * kWidth + u]);
      if (z > 0.45f) continue;
      s.positions.emplace_back((static_cast<float>(u) - kCx) * z / kF, (static_cast<float>(v) - kCy) * z / kF, z);
      s.colors.push_back(Rgb8{200, 30, 30});
      s.pixel_u.push_back(static_cast<std::int16_t>(u));
      s.pixel_v.push_back(static_cast<std::int16_t>(v));
      s.cluster.push_back(0);
    }
  }
  s.num_clusters = 1;
  s.standing_clusters = 1;
  return s;
}

template <class T>
LcmLogEvent event_of(const std::string& channel, const T& message, MessageAuthenticator* stamp = nullptr) {
  LcmLogEvent e;
  e.channel = channel;
  e.data.resize(static_cast<std::size_t>(message.getEncodedSize()));
  message.encode(e.data.data(), 0, static_cast<int>(e.data.size()));
  if (stamp != nullptr) stamp->stamp(e.data);
  return e;
}

class LogLabelImagesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("mfot_log_labels_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
  }
  void TearDown() override {
    install_message_authenticator(nullptr);
    fs::remove_all(dir_);
  }
  // The three messages of frame `seq` (the box shifted by `shift` columns), labels all `label`.
  struct Messages {
    LcmLogEvent frame, scene, segmentation;
    Image16 expected;
  };
  Messages messages(std::int64_t seq, int shift, std::int32_t label, MessageAuthenticator* stamp = nullptr) {
    const Frame f = test_frame(shift);
    const SceneCloud s = test_scene(f);
    const std::vector<std::int32_t> labels(s.size(), label);
    EncodeOptions rvl;
    rvl.depth = DepthEncoding::kRvl;
    const frame_t frame = encode_frame(f, rvl, seq, "test", 0);
    scene_cloud_t scene;
    scene_to_message(s, frame, scene);
    Messages m{event_of(channel::kFrame, frame, stamp), event_of(channel::kScene, scene, stamp),
               event_of(channel::kSegmentation, segmentation_message(seq, labels, 0), stamp),
               dense_labels(kWidth, kHeight, kF, kF, kCx, kCy, f.depth_mm, s.voxel_grid, s.positions, labels)};
    return m;
  }
  Image16 image(std::int64_t seq) const {
    char name[32];
    std::snprintf(name, sizeof name, "labels/%06lld.png", static_cast<long long>(seq));
    return read_png16((dir_ / name).string());
  }
  bool has_image(std::int64_t seq) const {
    char name[32];
    std::snprintf(name, sizeof name, "labels/%06lld.png", static_cast<long long>(seq));
    return fs::exists(dir_ / name);
  }
  fs::path dir_;
};

TEST_F(LogLabelImagesTest, DrawsEachFrameFromItsOwnMessagesInAnyOrder) {
  MalformedCounter rejected;
  LogLabelImages images(dir_.string(), 2, rejected);
  const Messages a = messages(1, 0, 1), b = messages(2, 3, 2), c = messages(3, 5, 3);
  // Frame 1's segmentation before its scene and frame; frames 2 and 3 interleaved.
  for (const LcmLogEvent* e : {&a.segmentation, &b.frame, &a.scene, &c.frame, &b.scene, &a.frame, &c.scene,
                               &c.segmentation, &b.segmentation}) {
    images.add(*e);
  }
  const LabelImageCounts counts = images.finish();
  EXPECT_EQ(counts.written, 3);
  EXPECT_EQ(counts.without_frame + counts.without_scene + counts.repeated + counts.mismatched, 0);
  EXPECT_EQ(rejected.total(), 0);
  for (const auto& [seq, m] : {std::pair{1, &a}, std::pair{2, &b}, std::pair{3, &c}}) {
    const Image16 drawn = image(seq);
    EXPECT_EQ(drawn.width, kWidth);
    EXPECT_EQ(drawn.pixels, m->expected.pixels) << "frame " << seq;
  }
  EXPECT_GT(std::count(a.expected.pixels.begin(), a.expected.pixels.end(), std::uint16_t{1}), 20);
  // The images differ (the box moved, its label changed), so each came from its own messages.
  EXPECT_NE(image(1).pixels, image(2).pixels);
}

TEST_F(LogLabelImagesTest, KeepsTheFirstSegmentationAndCountsWhatCannotBeDrawn) {
  MalformedCounter rejected;
  LogLabelImages images(dir_.string(), 1, rejected);
  const Messages first = messages(5, 0, 1), again = messages(5, 0, 7);
  for (const LcmLogEvent* e : {&first.frame, &first.scene, &first.segmentation, &again.segmentation, &again.scene}) {
    images.add(*e);
  }
  const Messages no_frame = messages(6, 0, 1);  // its frame was never recorded
  images.add(no_frame.scene);
  images.add(no_frame.segmentation);
  const Messages wrong = messages(7, 0, 1);
  segmentation_t short_labels = segmentation_message(7, std::vector<std::int32_t>(3, 1), 0);
  images.add(wrong.frame);
  images.add(wrong.scene);
  images.add(event_of(channel::kSegmentation, short_labels));
  const LabelImageCounts counts = images.finish();
  EXPECT_EQ(counts.written, 1);
  EXPECT_EQ(counts.repeated, 1);
  EXPECT_EQ(counts.without_frame, 1);
  EXPECT_EQ(counts.without_scene, 0);
  EXPECT_EQ(counts.mismatched, 1);
  EXPECT_EQ(image(5).pixels, first.expected.pixels);
  EXPECT_FALSE(has_image(6));
  EXPECT_FALSE(has_image(7));
}

TEST_F(LogLabelImagesTest, UnmatchedMessagesAreBoundedAndCounted) {
  MalformedCounter rejected;
  LogLabelImages images(dir_.string(), 1, rejected);
  // Segmentations of frames that were never recorded, more than are kept: the oldest are dropped and counted.
  const std::int64_t n = static_cast<std::int64_t>(LogLabelImages::kMaxPendingFrames) + 10;
  for (std::int64_t seq = 100; seq < 100 + n; ++seq) {
    images.add(event_of(channel::kSegmentation, segmentation_message(seq, std::vector<std::int32_t>(3, 1), 0)));
  }
  const LabelImageCounts counts = images.finish();
  EXPECT_EQ(counts.written, 0);
  EXPECT_EQ(counts.without_frame, n);
  EXPECT_EQ(counts.without_scene, n);
}

TEST_F(LogLabelImagesTest, DrawsOnlyTheRunsOwnGroup) {
  install_message_authenticator(std::make_shared<MessageAuthenticator>(1, 99, std::vector<std::uint8_t>{}));
  MessageAuthenticator ours(1, 5, {}), theirs(2, 5, {});
  MalformedCounter rejected;
  LogLabelImages images(dir_.string(), 1, rejected);
  const Messages own = messages(1, 0, 1, &ours);
  const Messages stranger = messages(1, 4, 9, &theirs);  // another group's frame 1, earlier in the log
  for (const LcmLogEvent* e :
       {&stranger.frame, &stranger.scene, &stranger.segmentation, &own.frame, &own.scene, &own.segmentation}) {
    images.add(*e);
  }
  const LabelImageCounts counts = images.finish();
  EXPECT_EQ(counts.written, 1);
  EXPECT_EQ(image(1).pixels, own.expected.pixels);
  EXPECT_EQ(message_authenticator()->counts().foreign, 3);
}

TEST_F(LogLabelImagesTest, AnUnwritableFolderIsNamed) {
  fs::create_directories(dir_);
  std::ofstream(dir_ / "labels") << "a file where the folder should be";
  MalformedCounter rejected;
  try {
    LogLabelImages images(dir_.string(), 1, rejected);
    FAIL() << "no error";
  } catch (const OutputError& e) {
    EXPECT_NE(std::string(e.what()).find((dir_ / "labels").string()), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mfot::service
