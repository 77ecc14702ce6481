// Every message type a service subscribes to, fed malformed bytes the way the services take them:
// the merger's scenes, estimates and heartbeats through its own handlers (MergerCore), a tracker's
// models through its own (TrackerWorker), frames and poses through decode_message() and the
// conversion the subscriber applies (decode_frame). Each malformed message must be
// rejected and counted once in the MalformedCounter, and valid messages must still pass after it.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "encoded_message.hpp"
#include "mfot/frame_done_t.hpp"
#include "mfot/frame_t.hpp"
#include "mfot/heartbeat_t.hpp"
#include "mfot/object_model_t.hpp"
#include "mfot/poses_t.hpp"
#include "mfot/scene_cloud_t.hpp"
#include "mfot/segmentation_t.hpp"
#include "mfot/service/convert.hpp"
#include "mfot/service/frame_codec.hpp"
#include "mfot/service/lcm_util.hpp"
#include "mfot/service/merger_core.hpp"
#include "mfot/service/tracker_worker.hpp"
#include "mfot/tracker_estimate_t.hpp"
#include "recording_merger_sink.hpp"

namespace mfot::service {
namespace {

using testing::Bytes;
using testing::encode;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// Overwrites the big-endian int32 at `offset` (LCM's wire order).
void patch_int32(Bytes& bytes, std::size_t offset, std::int32_t value) {
  ASSERT_LE(offset + 4, bytes.size());
  const auto bits = static_cast<std::uint32_t>(value);
  for (int i = 0; i < 4; ++i)
    bytes[offset + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(bits >> (24 - 8 * i));
}

std::int32_t read_int32(const Bytes& bytes, std::size_t offset) {
  std::uint32_t bits = 0;
  for (int i = 0; i < 4; ++i) bits = (bits << 8) | bytes.at(offset + static_cast<std::size_t>(i));
  return static_cast<std::int32_t>(bits);
}

template <class T>
bool decode(Bytes bytes, T& out, MalformedCounter& malformed, const std::string& channel_name) {
  const lcm::ReceiveBuffer buffer{bytes.data(), static_cast<std::uint32_t>(bytes.size()), 0};
  return decode_message(&buffer, channel_name, out, malformed);
}

// ---- the subscribers' acceptance, as in the services' handlers ---------------------------------

// preprocess / merger on MFOT_FRAME.
bool accept_frame(const Bytes& bytes, MalformedCounter& malformed) {
  frame_t message;
  if (!decode(bytes, message, malformed, channel::kFrame)) return false;
  try {
    decode_frame(message);
  } catch (const FrameCodecError& e) {
    malformed.record(channel::kFrame, "undecodable frame", e.what());
    return false;
  }
  return true;
}

// The merger's own handlers (MergerCore), on a fresh core: a message is accepted when nothing was
// counted as malformed.
bool merger_accepts(void (MergerCore::*handler)(const lcm::ReceiveBuffer*, const std::string&), Bytes bytes,
                    MalformedCounter& malformed, const char* channel_name, std::size_t* open_frames = nullptr) {
  testing::RecordingSink sink;
  testing::ManualClock clock;
  MergerCore core(MergerCoreOptions{}, sink, malformed, clock.function());
  const std::int64_t before = malformed.total();
  const lcm::ReceiveBuffer buffer{bytes.data(), static_cast<std::uint32_t>(bytes.size()), 0};
  (core.*handler)(&buffer, channel_name);
  if (open_frames != nullptr) *open_frames = core.open_frames();
  return malformed.total() == before;
}

// tracker / merger on MFOT_SCENE (the merger's handler; an accepted scene opens a frame).
bool accept_scene(const Bytes& bytes, MalformedCounter& malformed) {
  std::size_t open_frames = 0;
  const bool accepted = merger_accepts(&MergerCore::on_scene, bytes, malformed, channel::kScene, &open_frames);
  EXPECT_EQ(open_frames, accepted ? 1u : 0u);
  return accepted;
}

// tracker on MFOT_MODEL (the worker's own handler, TrackerWorker::on_model, on a fresh worker 0).
bool accept_model(const Bytes& bytes, MalformedCounter& malformed) {
  TrackerConfig config;
  config.likelihood.backend = LikelihoodBackend::kCpu;
  struct NoOutput : TrackerSink {
    void publish_estimate(const tracker_estimate_t&) override {}
    void publish_heartbeat(const heartbeat_t&) override {}
    void publish_model_report(const object_model_t&) override {}
    void note(const std::string&) override {}
  } sink;
  testing::ManualClock clock;
  TrackerWorker worker(config, {0, 0, "test"}, sink, malformed, clock.function());
  const std::int64_t before = malformed.total();
  Bytes copy = bytes;
  const lcm::ReceiveBuffer buffer{copy.data(), static_cast<std::uint32_t>(copy.size()), 0};
  worker.on_model(&buffer, channel::model_channel(0));
  return malformed.total() == before;
}

// tracker on MFOT_FRAME_DONE (TrackerWorker::on_frame_done, on a fresh worker 0).
bool accept_frame_done(const Bytes& bytes, MalformedCounter& malformed) {
  TrackerConfig config;
  config.likelihood.backend = LikelihoodBackend::kCpu;
  struct NoOutput : TrackerSink {
    void publish_estimate(const tracker_estimate_t&) override {}
    void publish_heartbeat(const heartbeat_t&) override {}
    void publish_model_report(const object_model_t&) override {}
    void note(const std::string&) override {}
  } sink;
  testing::ManualClock clock;
  TrackerWorker worker(config, {0, 0, "test"}, sink, malformed, clock.function());
  const std::int64_t before = malformed.total();
  Bytes copy = bytes;
  const lcm::ReceiveBuffer buffer{copy.data(), static_cast<std::uint32_t>(copy.size()), 0};
  worker.on_frame_done(&buffer, channel::kFrameDone);
  return malformed.total() == before;
}

// merger on MFOT_ESTIMATE.
bool accept_estimate(const Bytes& bytes, MalformedCounter& malformed) {
  return merger_accepts(&MergerCore::on_estimate, bytes, malformed, channel::kEstimate);
}

// merger on MFOT_HEARTBEAT.
bool accept_heartbeat(const Bytes& bytes, MalformedCounter& malformed) {
  return merger_accepts(&MergerCore::on_heartbeat, bytes, malformed, channel::kHeartbeat);
}

// capture (lockstep) on MFOT_POSES takes the decoded message as is.
bool accept_poses(const Bytes& bytes, MalformedCounter& malformed) {
  poses_t message;
  return decode(bytes, message, malformed, channel::kPoses);
}

// ---- valid messages -----------------------------------------------------------------------------

Frame make_frame(int width, int height) {
  Frame frame;
  frame.capture_utime = 99;
  frame.width = width;
  frame.height = height;
  frame.fx = frame.fy = 500.0f;
  frame.cx = width / 2.0f;
  frame.cy = height / 2.0f;
  for (int i = 0; i < width * height; ++i) {
    frame.depth_mm.push_back(static_cast<std::uint16_t>(700 + i));
    frame.color.push_back(Rgb8{static_cast<std::uint8_t>(i), 100, static_cast<std::uint8_t>(255 - i)});
  }
  return frame;
}

frame_t make_frame_message(DepthEncoding depth = DepthEncoding::kRaw, ColorEncoding color = ColorEncoding::kRaw) {
  return encode_frame(make_frame(6, 4), EncodeOptions{depth, color, 90, 1}, 5, "test", 1000);
}

scene_cloud_t make_scene(int n) {
  scene_cloud_t msg{};
  msg.frame_seq = 5;
  msg.width = 640;
  msg.height = 480;
  msg.fx = msg.fy = 525.0f;
  msg.voxel_size = 0.005f;
  msg.num_points = n;
  msg.num_clusters = 1;
  msg.num_standing_clusters = 1;
  for (int i = 0; i < n; ++i) {
    msg.x.push_back(0.01f * i);
    msg.y.push_back(0.02f);
    msg.z.push_back(0.9f);
    msg.r.push_back(10);
    msg.g.push_back(20);
    msg.b.push_back(30);
    msg.u.push_back(static_cast<std::int16_t>(i));
    msg.v.push_back(7);
    msg.cluster.push_back(0);
  }
  return msg;
}

object_model_t make_model(int n) {
  object_model_t msg{};
  msg.object_id = 1;
  msg.worker_id = 0;
  msg.orientation[0] = 1.0;
  msg.position[2] = 0.8;
  msg.num_points = n;
  for (int i = 0; i < n; ++i) {
    msg.x.push_back(0.001f * i);
    msg.y.push_back(0.0f);
    msg.z.push_back(-0.001f * i);
    msg.r.push_back(1);
    msg.g.push_back(2);
    msg.b.push_back(3);
  }
  return msg;
}

tracker_estimate_t make_estimate() {
  tracker_estimate_t msg{};
  msg.frame_seq = 5;
  msg.object_id = 1;
  msg.position[2] = 0.8;
  msg.orientation[0] = std::sqrt(0.5);
  msg.orientation[3] = std::sqrt(0.5);
  msg.confidence = 0.7f;
  msg.num_particles = 100;
  return msg;
}

heartbeat_t make_heartbeat() {
  heartbeat_t msg{};
  msg.utime = 1;
  msg.worker_id = 2;
  msg.instance = 77;
  msg.host = "host-a";
  msg.object_id = -1;
  msg.last_frame_seq = -1;
  return msg;
}

poses_t make_poses(int n) {
  poses_t msg{};
  msg.frame_seq = 5;
  msg.num_objects = n;
  for (int i = 0; i < n; ++i) {
    object_pose_t pose{};
    pose.id = i + 1;
    pose.orientation[0] = pose.world_orientation[0] = 1.0;
    pose.confidence = 0.5f;
    msg.objects.push_back(pose);
  }
  return msg;
}

// Two objects, the second with `claimed` claimed points.
frame_done_t make_frame_done(int claimed) {
  frame_done_t msg{};
  msg.frame_seq = 5;
  for (int i = 0; i < 2; ++i) {
    frame_done_object_t entry{};
    entry.object_id = i + 1;
    entry.worker_id = i;
    entry.version = 3;
    entry.orientation[0] = 1.0;
    msg.objects.push_back(entry);
  }
  for (int i = 0; i < claimed; ++i) {
    msg.objects[1].claimed_x.push_back(0.1f * static_cast<float>(i));
    msg.objects[1].claimed_y.push_back(0.f);
    msg.objects[1].claimed_z.push_back(1.f);
  }
  msg.objects[1].num_claimed = claimed;
  msg.num_objects = 2;
  return msg;
}

// Wire offsets of the array counts (8-byte fingerprint first; see the .lcm field order). Every type has
// envelope_t (56 bytes) right after utime.
constexpr std::size_t kEnvelope = 56;
constexpr std::size_t kSceneNumPoints = 8 + 24 + kEnvelope + 8 + 20 + 12 + 16;  // ... voxel_origin 12, plane 16
// object_model_t: ... carried_by, companion | is_delta 1, base_version, num_base_points 8 | num_base_runs ...
constexpr std::size_t kModelNumBaseRuns = 8 + 16 + kEnvelope + 8 + 8 + 4 + 104 + 4 + 52 + 1 + 8;
constexpr std::size_t kModelNumOrderRuns = kModelNumBaseRuns + 4;  // (make_model: no runs)
constexpr std::size_t kModelNumPoints = kModelNumOrderRuns + 4;
constexpr std::size_t kModelNumClaimed = kModelNumPoints + 4 + 5 * 15;  // after make_model(5)'s points
constexpr std::size_t kPosesNumObjects = 8 + 24 + kEnvelope;
constexpr std::size_t kFrameDoneNumObjects = 8 + 16 + kEnvelope;
constexpr std::size_t kFrameDoneEntry = 4 + 4 + 8 + 4 + 56 + 8 + 48;  // fixed fields of one frame_done_object_t
// The second entry's num_claimed (the first has none).
constexpr std::size_t kFrameDoneSecondNumClaimed = kFrameDoneNumObjects + 4 + kFrameDoneEntry + 4 + kFrameDoneEntry;
std::size_t frame_depth_size_offset(const frame_t& msg) {
  return 8 + 24 + kEnvelope + 4 + msg.source.size() + 1 + 24 + 1;
}

// ---- checks shared by every type ----------------------------------------------------------------

using Accept = bool (*)(const Bytes&, MalformedCounter&);

// Every malformed input is rejected and counted exactly once; the valid one passes before and
// after them without being counted.
void expect_rejected_and_counted(Accept accept, const Bytes& valid, const std::vector<Bytes>& malformed_inputs) {
  MalformedCounter malformed;
  ASSERT_TRUE(accept(valid, malformed));
  ASSERT_EQ(malformed.total(), 0);
  for (std::size_t i = 0; i < malformed_inputs.size(); ++i) {
    EXPECT_FALSE(accept(malformed_inputs[i], malformed)) << "input " << i;
    EXPECT_EQ(malformed.total(), static_cast<std::int64_t>(i + 1)) << "input " << i;
  }
  EXPECT_TRUE(accept(valid, malformed));
  EXPECT_EQ(malformed.total(), static_cast<std::int64_t>(malformed_inputs.size()));
}

// Every strict prefix, the message with one byte too many, and the message with each
// fingerprint byte changed.
std::vector<Bytes> truncations_and_bad_fingerprints(const Bytes& valid) {
  std::vector<Bytes> out;
  for (std::size_t n = 0; n < valid.size(); ++n) out.emplace_back(valid.begin(), valid.begin() + static_cast<long>(n));
  Bytes longer = valid;
  longer.push_back(0);
  out.push_back(longer);
  for (std::size_t i = 0; i < 8; ++i) {
    Bytes changed = valid;
    changed[i] ^= 0x10;
    out.push_back(changed);
  }
  return out;
}

struct Case {
  const char* name;
  Accept accept;
  Bytes valid;
};

std::vector<Case> every_subscribed_type() {
  return {{"frame_t", accept_frame, encode(make_frame_message())},
          {"scene_cloud_t", accept_scene, encode(make_scene(5))},
          {"object_model_t", accept_model, encode(make_model(5))},
          {"tracker_estimate_t", accept_estimate, encode(make_estimate())},
          {"heartbeat_t", accept_heartbeat, encode(make_heartbeat())},
          {"poses_t", accept_poses, encode(make_poses(2))},
          {"frame_done_t", accept_frame_done, encode(make_frame_done(3))}};
}

TEST(MalformedMessages, TruncatedOverlongAndWrongFingerprintAreRejected) {
  for (const Case& c : every_subscribed_type()) {
    SCOPED_TRACE(c.name);
    expect_rejected_and_counted(c.accept, c.valid, truncations_and_bad_fingerprints(c.valid));
  }
}

TEST(MalformedMessages, AnotherTypesBytesAreRejected) {
  const auto cases = every_subscribed_type();
  for (const Case& receiver : cases) {
    std::vector<Bytes> others;
    for (const Case& sender : cases) {
      if (sender.name != receiver.name) others.push_back(sender.valid);
    }
    SCOPED_TRACE(receiver.name);
    expect_rejected_and_counted(receiver.accept, receiver.valid, others);
  }
}

// num_points / num_objects / depth_size patched to absurd, negative and off-by-one values. The
// absurd ones must be refused before lcm's decode allocates the declared arrays (a 2e9-point
// scene would otherwise zero 8 GB); this test would take seconds and gigabytes without that.
std::vector<Bytes> patched_counts(const Bytes& valid, std::size_t offset) {
  const std::int32_t n = read_int32(valid, offset);
  std::vector<Bytes> out;
  for (const std::int32_t value : {2000000000, std::numeric_limits<std::int32_t>::max(), 1 << 24, n + 1, n - 1, -1,
                                   std::numeric_limits<std::int32_t>::min()}) {
    Bytes patched = valid;
    patch_int32(patched, offset, value);
    out.push_back(patched);
  }
  return out;
}

TEST(MalformedMessages, AbsurdAndNegativeArraySizesAreRejected) {
  const Bytes scene = encode(make_scene(5));
  ASSERT_EQ(read_int32(scene, kSceneNumPoints), 5);
  expect_rejected_and_counted(accept_scene, scene, patched_counts(scene, kSceneNumPoints));

  object_model_t claiming = make_model(5);
  claiming.num_claimed = 2;
  claiming.claimed_x = claiming.claimed_y = claiming.claimed_z = {0.1f, 0.2f};
  const Bytes model = encode(claiming);
  ASSERT_EQ(read_int32(model, kModelNumPoints), 5);
  ASSERT_EQ(read_int32(model, kModelNumClaimed), 2);
  auto model_inputs = patched_counts(model, kModelNumPoints);
  for (const std::size_t offset : {kModelNumBaseRuns, kModelNumOrderRuns, kModelNumClaimed}) {
    for (auto& patched : patched_counts(model, offset)) model_inputs.push_back(patched);
  }
  expect_rejected_and_counted(accept_model, model, model_inputs);

  const Bytes poses = encode(make_poses(2));
  ASSERT_EQ(read_int32(poses, kPosesNumObjects), 2);
  expect_rejected_and_counted(accept_poses, poses, patched_counts(poses, kPosesNumObjects));

  const Bytes frame_done = encode(make_frame_done(3));
  ASSERT_EQ(read_int32(frame_done, kFrameDoneNumObjects), 2);
  ASSERT_EQ(read_int32(frame_done, kFrameDoneSecondNumClaimed), 3);
  auto frame_done_inputs = patched_counts(frame_done, kFrameDoneNumObjects);
  for (auto& patched : patched_counts(frame_done, kFrameDoneSecondNumClaimed)) frame_done_inputs.push_back(patched);
  expect_rejected_and_counted(accept_frame_done, frame_done, frame_done_inputs);

  const frame_t frame_message = make_frame_message();
  const Bytes frame = encode(frame_message);
  const std::size_t depth_offset = frame_depth_size_offset(frame_message);
  ASSERT_EQ(read_int32(frame, depth_offset), frame_message.depth_size);
  auto frame_inputs = patched_counts(frame, depth_offset);
  const std::size_t color_offset = depth_offset + 4 + frame_message.depth_data.size() + 1;
  ASSERT_EQ(read_int32(frame, color_offset), frame_message.color_size);
  for (auto& patched : patched_counts(frame, color_offset)) frame_inputs.push_back(patched);
  expect_rejected_and_counted(accept_frame, frame, frame_inputs);
}

// The MalformedCounter names the reason: an absurd size is "bad array size", not a decode of
// garbage.
TEST(MalformedMessages, AbsurdSizeIsCountedAsBadArraySize) {
  Bytes scene = encode(make_scene(5));
  patch_int32(scene, kSceneNumPoints, 2000000000);
  MalformedCounter malformed;
  EXPECT_FALSE(accept_scene(scene, malformed));
  EXPECT_NE(malformed.last().find("bad array size"), std::string::npos) << malformed.last();
}

TEST(MalformedMessages, NonFiniteCoordinatesAreRejected) {
  constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();
  constexpr float kInff = std::numeric_limits<float>::infinity();
  std::vector<Bytes> scenes;
  for (const float value : {kNaNf, kInff, -kInff}) {
    auto x = make_scene(5);
    x.x[0] = value;
    scenes.push_back(encode(x));
    auto z = make_scene(5);
    z.z[4] = value;
    scenes.push_back(encode(z));
  }
  auto voxel = make_scene(5);
  voxel.voxel_size = kNaNf;
  scenes.push_back(encode(voxel));
  expect_rejected_and_counted(accept_scene, encode(make_scene(5)), scenes);

  std::vector<Bytes> models;
  for (const float value : {kNaNf, kInff}) {
    auto point = make_model(5);
    point.y[2] = value;
    models.push_back(encode(point));
  }
  for (const double value : {kNaN, kInf}) {
    auto position = make_model(5);
    position.position[1] = value;
    models.push_back(encode(position));
    auto orientation = make_model(5);
    orientation.orientation[0] = value;
    models.push_back(encode(orientation));
    auto velocity = make_model(5);
    velocity.velocity[5] = value;
    models.push_back(encode(velocity));
  }
  expect_rejected_and_counted(accept_model, encode(make_model(5)), models);

  std::vector<Bytes> estimates;
  for (const double value : {kNaN, kInf, -kInf}) {
    auto position = make_estimate();
    position.position[0] = value;
    estimates.push_back(encode(position));
    auto orientation = make_estimate();
    orientation.orientation[2] = value;
    estimates.push_back(encode(orientation));
    auto confidence = make_estimate();
    confidence.confidence = static_cast<float>(value);
    estimates.push_back(encode(confidence));
  }
  auto not_unit = make_estimate();
  not_unit.orientation[0] = 0.0;
  estimates.push_back(encode(not_unit));
  expect_rejected_and_counted(accept_estimate, encode(make_estimate()), estimates);

  std::vector<Bytes> frames;
  for (const float value : {kNaNf, kInff, 0.0f, -500.0f}) {
    auto focal = make_frame_message();
    focal.fx = value;
    frames.push_back(encode(focal));
  }
  auto centre = make_frame_message();
  centre.cy = kNaNf;
  frames.push_back(encode(centre));
  expect_rejected_and_counted(accept_frame, encode(make_frame_message()), frames);
}

TEST(MalformedMessages, FramesWhosePayloadDisagreesWithTheHeaderAreRejected) {
  std::vector<Bytes> frames;
  // Consistent depth_size field, but fewer/more bytes than width x height x 2.
  auto short_depth = make_frame_message();
  short_depth.depth_data.resize(short_depth.depth_data.size() - 2);
  short_depth.depth_size = static_cast<std::int32_t>(short_depth.depth_data.size());
  frames.push_back(encode(short_depth));
  auto wider = make_frame_message();
  wider.width += 1;
  frames.push_back(encode(wider));
  auto taller = make_frame_message();
  taller.height *= 2;
  frames.push_back(encode(taller));
  auto short_color = make_frame_message();
  short_color.color_data.pop_back();
  short_color.color_size -= 1;
  frames.push_back(encode(short_color));
  // Compressed payloads for a different size, or corrupt.
  auto zlib = make_frame_message(DepthEncoding::kZlib, ColorEncoding::kPng);
  zlib.width = 3;
  frames.push_back(encode(zlib));
  auto corrupt_zlib = make_frame_message(DepthEncoding::kZlib, ColorEncoding::kRaw);
  corrupt_zlib.depth_data[corrupt_zlib.depth_data.size() / 2] ^= 0x5a;
  corrupt_zlib.depth_data.pop_back();
  corrupt_zlib.depth_size -= 1;
  frames.push_back(encode(corrupt_zlib));
  auto jpeg = make_frame_message(DepthEncoding::kRaw, ColorEncoding::kJpeg);
  jpeg.color_data.resize(jpeg.color_data.size() / 2);
  jpeg.color_size = static_cast<std::int32_t>(jpeg.color_data.size());
  frames.push_back(encode(jpeg));
  // Sizes and encodings out of range.
  auto zero = make_frame_message();
  zero.width = 0;
  frames.push_back(encode(zero));
  auto negative = make_frame_message();
  negative.height = -4;
  frames.push_back(encode(negative));
  auto huge = make_frame_message();
  huge.width = kMaxFrameSide + 1;
  frames.push_back(encode(huge));
  auto depth_encoding = make_frame_message();
  depth_encoding.depth_encoding = 7;
  frames.push_back(encode(depth_encoding));
  auto color_encoding = make_frame_message();
  color_encoding.color_encoding = -1;
  frames.push_back(encode(color_encoding));
  expect_rejected_and_counted(accept_frame, encode(make_frame_message()), frames);

  // Each valid encoding still passes.
  MalformedCounter malformed;
  for (const auto depth : {DepthEncoding::kRaw, DepthEncoding::kZlib}) {
    for (const auto color : {ColorEncoding::kRaw, ColorEncoding::kJpeg, ColorEncoding::kPng}) {
      EXPECT_TRUE(accept_frame(encode(make_frame_message(depth, color)), malformed));
    }
  }
  EXPECT_EQ(malformed.total(), 0);
}

TEST(MalformedMessages, SceneArraysInconsistentWithClustersAreRejected) {
  auto cluster = make_scene(5);
  cluster.cluster[3] = 1;  // num_clusters is 1
  auto none = make_scene(5);
  none.cluster[0] = -2;
  expect_rejected_and_counted(accept_scene, encode(make_scene(5)), {encode(cluster), encode(none)});
}

TEST(MalformedMessages, EmptyArraysAreValid) {
  MalformedCounter malformed;
  EXPECT_TRUE(accept_scene(encode(make_scene(0)), malformed));
  object_model_t retirement = make_model(0);  // no points: how the merger retires an object
  retirement.worker_id = -1;
  EXPECT_TRUE(accept_model(encode(retirement), malformed));
  EXPECT_TRUE(accept_poses(encode(make_poses(0)), malformed));
  EXPECT_EQ(malformed.total(), 0);
  // Assigned to a worker, a model without points is refused by it.
  EXPECT_FALSE(accept_model(encode(make_model(0)), malformed));
}

// segmentation_t has no subscriber among the services, but its count is guarded as well.
TEST(MalformedMessages, SegmentationCountIsGuarded) {
  segmentation_t msg{};
  msg.num_points = 3;
  msg.label = {0, 1, 2};
  Bytes bytes = encode(msg);
  MalformedCounter malformed;
  segmentation_t out;
  ASSERT_TRUE(decode(bytes, out, malformed, channel::kSegmentation));
  patch_int32(bytes, 8 + 16 + kEnvelope, 2000000000);
  EXPECT_FALSE(decode(bytes, out, malformed, channel::kSegmentation));
  EXPECT_EQ(malformed.total(), 1);
}

}  // namespace
}  // namespace mfot::service
