// One object's tracker (ObjectTracker) and a tracker worker's protocol (TrackerWorker) without LCM:
// the same estimates as driving the filter and the step by hand, a grid only for a new model
// version, and the worker's handlers fed encoded messages.

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <vector>

#include "../core/synthetic_object.hpp"
#include "encoded_message.hpp"
#include "mfot/frame_done_t.hpp"
#include "mfot/jcsd_likelihood.hpp"
#include "mfot/object_model_t.hpp"
#include "mfot/scene_cloud_t.hpp"
#include "mfot/service/merger_messages.hpp"
#include "mfot/service/object_tracker.hpp"
#include "mfot/service/tracker_worker.hpp"

namespace mfot::service {
namespace {

using testing::Bytes;
using testing::encode;

ObjectTrackerOptions cpu_options() {
  ObjectTrackerOptions o;
  o.likelihood.backend = LikelihoodBackend::kCpu;
  o.filter.num_particles = 50;
  o.filter.seed = 11;
  o.step.hold_occluded_share = 0.6f;
  return o;
}

const ObjectModel kModel = test::make_model(test::make_test_object(0.f));
const Pose kStart = test::make_pose(Eigen::Vector3f(0.f, 0.f, 1.f), Eigen::Vector3f::UnitY(), 0.2f);

// The object moved a little in frame k.
ColoredCloud scene_at(int k) {
  Pose pose = kStart;
  pose.translation.x() += 0.003f * static_cast<float>(k);
  return test::transformed(test::make_test_object(0.3f), pose);
}

TEST(ObjectTracker, EstimatesAreThoseOfTheFilterAndStepDrivenByHand) {
  const ObjectTrackerOptions options = cpu_options();
  ObjectTracker tracker(options);
  EXPECT_TRUE(tracker.set_model(3, 1, kModel, kStart));
  ParticleFilterOptions filter_options = options.filter;
  filter_options.seed += 3;  // the object's id
  ParticleFilter filter(filter_options);
  filter.reset(kStart);
  TrackingStep step(options.step);
  JcsdLikelihood likelihood;
  likelihood.set_model(kModel);
  for (int k = 1; k <= 4; ++k) {
    const ColoredCloud scene = scene_at(k);
    const TrackingStepResult got = tracker.track(scene);
    const TrackingStepResult expected = step.track(scene, kModel, model_bounding_box(kModel), filter, likelihood);
    EXPECT_EQ(got.estimate.translation, expected.estimate.translation) << k;
    EXPECT_EQ(got.estimate.rotation.coeffs(), expected.estimate.rotation.coeffs()) << k;
    EXPECT_EQ(got.hypothesis_points, expected.hypothesis_points) << k;
  }
}

TEST(ObjectTracker, BuildsAGridOnlyForANewObjectOrModelVersion) {
  ObjectTracker tracker(cpu_options());
  EXPECT_FALSE(tracker.has_object());
  EXPECT_THROW(tracker.track(scene_at(0)), std::logic_error);
  EXPECT_TRUE(tracker.set_model(3, 1, kModel, kStart));
  EXPECT_EQ(tracker.grid_builds(), 1);
  for (int k = 0; k < 3; ++k) EXPECT_FALSE(tracker.set_model(3, 1, kModel, kStart));  // every frame, same version
  EXPECT_EQ(tracker.grid_builds(), 1);
  ObjectModel grown = kModel;
  grown.cloud.push_back(Eigen::Vector3f(0.f, 0.f, 0.06f), Rgb8{1, 2, 3});
  grown.features = compute_smr(grown.cloud.colors);
  EXPECT_FALSE(tracker.set_model(3, 2, grown, kStart));
  EXPECT_EQ(tracker.grid_builds(), 2);
  EXPECT_EQ(tracker.model().cloud.size(), grown.cloud.size());
  EXPECT_EQ(tracker.model_version(), 2);
  // Carried by another object: the filter moves to the merger's pose, without a new grid.
  Pose carried = kStart;
  carried.translation.x() += 0.05f;
  EXPECT_FALSE(tracker.set_model(3, 2, grown, carried, true));
  EXPECT_EQ(tracker.grid_builds(), 2);
  EXPECT_EQ(tracker.filter().estimate().translation, carried.translation);
  tracker.drop();
  EXPECT_FALSE(tracker.has_object());
  EXPECT_TRUE(tracker.set_model(3, 2, grown, kStart));  // taken again: a new filter
  EXPECT_EQ(tracker.grid_builds(), 3);
}

TEST(ObjectTracker, HoldsNothingOfAnObjectOnceDropped) {
  // A worker runs for hours and takes objects in turn: once one is dropped neither its grid nor its
  // model may stay (megabytes for a large model), or an idle worker keeps the largest it ever held.
  ObjectTracker tracker(cpu_options());
  const auto* jcsd = dynamic_cast<const JcsdLikelihood*>(tracker.likelihood().likelihood.get());
  ASSERT_NE(jcsd, nullptr);
  for (std::int32_t id = 1; id <= 20; ++id) {
    EXPECT_TRUE(tracker.set_model(id, 1, kModel, kStart));
    tracker.track(scene_at(1));
    EXPECT_FALSE(jcsd->grid().empty()) << id;
    tracker.drop();
    EXPECT_FALSE(tracker.has_object()) << id;
    EXPECT_TRUE(jcsd->grid().empty()) << id;
    EXPECT_EQ(jcsd->grid().values.capacity(), 0u) << id;
    EXPECT_EQ(tracker.model().cloud.size(), 0u) << id;
    EXPECT_EQ(tracker.model().features.capacity(), 0u) << id;
  }
  // Taken again after a drop: tracked as a new object, with a new grid.
  EXPECT_TRUE(tracker.set_model(1, 1, kModel, kStart));
  EXPECT_FALSE(jcsd->grid().empty());
  EXPECT_EQ(tracker.model().cloud.size(), kModel.cloud.size());
}

TEST(ObjectTracker, ANewObjectStartsAsAFreshTrackerWould) {
  ObjectTracker reused(cpu_options());
  reused.set_model(3, 1, kModel, kStart);
  reused.track(scene_at(1));
  reused.track(scene_at(2));
  ObjectTracker fresh(cpu_options());
  EXPECT_TRUE(reused.set_model(5, 1, kModel, kStart));
  fresh.set_model(5, 1, kModel, kStart);
  for (int k = 1; k <= 3; ++k) {
    EXPECT_EQ(reused.track(scene_at(k)).estimate.translation, fresh.track(scene_at(k)).estimate.translation) << k;
  }
}

// ---- TrackerWorker ------------------------------------------------------------------------------

class RecordingTrackerSink : public TrackerSink {
 public:
  void publish_estimate(const tracker_estimate_t& estimate) override { estimates.push_back(estimate); }
  void publish_heartbeat(const heartbeat_t& heartbeat) override { heartbeats.push_back(heartbeat); }
  void publish_model_report(const object_model_t& report) override { reports.push_back(report); }
  void note(const std::string& message) override { notes.push_back(message); }
  std::vector<object_model_t> reports;
  std::vector<tracker_estimate_t> estimates;
  std::vector<heartbeat_t> heartbeats;
  std::vector<std::string> notes;
};

object_model_t model_for(std::int32_t object_id, std::int32_t worker_id, std::int64_t instance,
                         std::int64_t frame_seq) {
  object_model_t msg{};
  msg.frame_seq = frame_seq;
  msg.object_id = object_id;
  msg.worker_id = worker_id;
  msg.worker_instance = instance;
  msg.version = 1;
  pose_to_arrays(kStart, msg.position, msg.orientation);
  model_to_message(kModel, msg);
  return msg;
}

scene_cloud_t scene_message(std::int64_t seq) {
  const ColoredCloud cloud = scene_at(static_cast<int>(seq));
  scene_cloud_t msg{};
  msg.frame_seq = seq;
  msg.width = 640;
  msg.height = 480;
  msg.fx = msg.fy = 525.f;
  msg.voxel_size = 0.005f;
  msg.num_clusters = 1;
  msg.num_standing_clusters = 1;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    msg.x.push_back(cloud.positions[i].x());
    msg.y.push_back(cloud.positions[i].y());
    msg.z.push_back(cloud.positions[i].z());
    msg.r.push_back(cloud.colors[i].r);
    msg.g.push_back(cloud.colors[i].g);
    msg.b.push_back(cloud.colors[i].b);
    msg.u.push_back(0);
    msg.v.push_back(0);
    msg.cluster.push_back(0);
  }
  msg.num_points = static_cast<std::int32_t>(msg.x.size());
  return msg;
}

struct TrackerWorkerTest : ::testing::Test {
  static TrackerConfig config() {
    TrackerConfig c;
    const ObjectTrackerOptions o = cpu_options();
    c.likelihood = o.likelihood;
    c.filter = o.filter;
    c.step = o.step;
    return c;
  }
  template <class T>
  void deliver(void (TrackerWorker::*handler)(const lcm::ReceiveBuffer*, const std::string&), const T& message) {
    Bytes bytes = encode(message);
    const lcm::ReceiveBuffer buffer{bytes.data(), static_cast<std::uint32_t>(bytes.size()), 0};
    (worker.*handler)(&buffer, "TEST");
  }
  RecordingTrackerSink sink;
  MalformedCounter malformed;
  std::chrono::steady_clock::time_point now{std::chrono::seconds(100)};
  TrackerWorker worker{config(), {4, 444, "host-a"}, sink, malformed, [this] { return now; }};
};

TEST_F(TrackerWorkerTest, TracksTheObjectAddressedToThisProcessAndHeartbeatsIt) {
  worker.step();
  ASSERT_EQ(sink.heartbeats.size(), 1u);  // at once: the merger learns the worker
  EXPECT_EQ(sink.heartbeats[0].object_id, -1);
  EXPECT_EQ(sink.heartbeats[0].instance, 444);
  EXPECT_EQ(sink.heartbeats[0].host, "host-a");
  // Worker id 4 in another process (a clash): not ours.
  deliver(&TrackerWorker::on_model, model_for(7, 4, 555, 0));
  EXPECT_FALSE(worker.tracker().has_object());
  deliver(&TrackerWorker::on_model, model_for(7, 4, 444, 0));
  ASSERT_TRUE(worker.tracker().has_object());
  EXPECT_EQ(worker.tracker().object_id(), 7);
  deliver(&TrackerWorker::on_scene, scene_message(1));
  EXPECT_EQ(worker.step(), 1);
  ASSERT_EQ(sink.estimates.size(), 1u);
  EXPECT_EQ(sink.estimates[0].frame_seq, 1);
  EXPECT_EQ(sink.estimates[0].object_id, 7);
  EXPECT_EQ(sink.estimates[0].worker_id, 4);
  EXPECT_GT(sink.estimates[0].num_hypothesis_points, 0);
  now += std::chrono::milliseconds(150);
  worker.step();
  EXPECT_EQ(sink.heartbeats.back().object_id, 7);
  EXPECT_EQ(sink.heartbeats.back().last_frame_seq, 1);
  // The object moves to another worker: dropped.
  deliver(&TrackerWorker::on_model, model_for(7, 9, 999, 1));
  EXPECT_FALSE(worker.tracker().has_object());
  EXPECT_EQ(malformed.total(), 0);
}

TEST(TrackerWorker, WhatTheModelSaysOtherObjectsClaimIsLeftOutOfTheNextScene) {
  TrackerConfig c = TrackerWorkerTest::config();
  c.step.exclude_claimed_radius = 0.01f;
  RecordingTrackerSink sink;
  MalformedCounter malformed;
  const auto now = std::chrono::steady_clock::time_point{std::chrono::seconds(100)};
  TrackerWorker worker{c, {4, 444, "host-a"}, sink, malformed, [now] { return now; }};
  const scene_cloud_t scene = scene_message(1);
  // Nothing claimed: every point near the object is scored.
  auto deliver_to = [&worker](auto handler, const auto& message) {
    Bytes bytes = encode(message);
    const lcm::ReceiveBuffer buffer{bytes.data(), static_cast<std::uint32_t>(bytes.size()), 0};
    (worker.*handler)(&buffer, "TEST");
  };
  deliver_to(&TrackerWorker::on_model, model_for(7, 4, 444, 0));
  deliver_to(&TrackerWorker::on_scene, scene);
  ASSERT_EQ(worker.step(), 1);
  ASSERT_EQ(sink.estimates.size(), 1u);
  EXPECT_EQ(sink.estimates[0].num_hypothesis_points, scene.num_points);
  // The next model says another object's model lies on every point of the scene: none is scored.
  object_model_t claiming = model_for(7, 4, 444, 1);
  std::vector<Eigen::Vector3f> claimed;
  for (std::size_t i = 0; i < scene.x.size(); ++i) claimed.emplace_back(scene.x[i], scene.y[i], scene.z[i]);
  claimed_to_message(claimed, claiming);
  deliver_to(&TrackerWorker::on_model, claiming);
  scene_cloud_t next = scene_message(2);
  next.x = scene.x, next.y = scene.y, next.z = scene.z;
  deliver_to(&TrackerWorker::on_scene, next);
  ASSERT_EQ(worker.step(), 1);
  ASSERT_EQ(sink.estimates.size(), 2u);
  EXPECT_EQ(sink.estimates[1].num_hypothesis_points, 0);
  EXPECT_EQ(malformed.total(), 0);
}

// A model whose carried_by is set (the merger carried the hidden object with another) moves the
// filter to its pose; an ordinary model leaves the filter where it is. The estimate tells whether the
// filter held.
TEST_F(TrackerWorkerTest, ACarriedModelMovesTheFilterAndHoldsAreReported) {
  deliver(&TrackerWorker::on_model, model_for(7, 4, 444, 0));
  deliver(&TrackerWorker::on_scene, scene_message(1));
  ASSERT_EQ(worker.step(), 1);
  ASSERT_EQ(sink.estimates.size(), 1u);
  EXPECT_FALSE(sink.estimates[0].held);
  const Pose tracked = worker.tracker().filter().estimate();
  deliver(&TrackerWorker::on_model, model_for(7, 4, 444, 1));  // the merger's pose is kStart: ignored
  EXPECT_EQ(worker.tracker().filter().estimate().translation, tracked.translation);
  object_model_t carried = model_for(7, 4, 444, 2);
  Pose away = kStart;
  away.translation += Eigen::Vector3f(0.04f, -0.01f, 0.02f);
  pose_to_arrays(away, carried.position, carried.orientation);
  carried.carried_by = 3;
  deliver(&TrackerWorker::on_model, carried);
  EXPECT_LT((worker.tracker().filter().estimate().translation - away.translation).norm(), 1e-6f);
  // Hidden: a plate 3 cm in front of the whole object at its new pose, nothing of it in view.
  scene_cloud_t hidden = scene_message(3);
  hidden.x.clear(), hidden.y.clear(), hidden.z.clear(), hidden.r.clear(), hidden.g.clear(), hidden.b.clear();
  hidden.u.clear(), hidden.v.clear(), hidden.cluster.clear();
  for (float x = -0.15f; x <= 0.15f; x += 0.004f) {
    for (float y = -0.15f; y <= 0.15f; y += 0.004f) {
      hidden.x.push_back(away.translation.x() + x), hidden.y.push_back(away.translation.y() + y);
      hidden.z.push_back(away.translation.z() - 0.09f);
      hidden.r.push_back(220), hidden.g.push_back(170), hidden.b.push_back(140);
      hidden.u.push_back(0), hidden.v.push_back(0), hidden.cluster.push_back(0);
    }
  }
  hidden.num_points = static_cast<std::int32_t>(hidden.x.size());
  deliver(&TrackerWorker::on_scene, hidden);
  ASSERT_EQ(worker.step(), 1);
  ASSERT_EQ(sink.estimates.size(), 2u);
  EXPECT_TRUE(sink.estimates[1].held);
  EXPECT_LT((Eigen::Vector3f(static_cast<float>(sink.estimates[1].position[0]),
                             static_cast<float>(sink.estimates[1].position[1]),
                             static_cast<float>(sink.estimates[1].position[2])) -
             away.translation)
                .norm(),
            1e-6f);
  EXPECT_EQ(malformed.total(), 0);
}

TEST_F(TrackerWorkerTest, MalformedModelsAndScenesAreCountedAndTheWorkerGoesOn) {
  Bytes truncated = encode(model_for(7, 4, 444, 0));
  truncated.resize(truncated.size() - 3);
  const lcm::ReceiveBuffer half{truncated.data(), static_cast<std::uint32_t>(truncated.size()), 0};
  worker.on_model(&half, "MFOT_MODEL");
  object_model_t empty = model_for(7, 4, 444, 0);
  empty.num_points = 0;
  empty.x.clear(), empty.y.clear(), empty.z.clear(), empty.r.clear(), empty.g.clear(), empty.b.clear();
  deliver(&TrackerWorker::on_model, empty);
  scene_cloud_t bad_scene = scene_message(1);
  bad_scene.cluster[0] = 5;  // beyond num_clusters
  deliver(&TrackerWorker::on_scene, bad_scene);
  object_model_t bad_claim = model_for(7, 4, 444, 0);
  claimed_to_message(std::vector<Eigen::Vector3f>{{0.f, std::nanf(""), 1.f}}, bad_claim);
  deliver(&TrackerWorker::on_model, bad_claim);
  object_model_t own_companion = model_for(7, 4, 444, 0);
  own_companion.companion = 7;
  deliver(&TrackerWorker::on_model, own_companion);
  EXPECT_EQ(malformed.total(), 5);
  EXPECT_FALSE(worker.tracker().has_object());
  deliver(&TrackerWorker::on_model, model_for(7, 4, 444, 0));
  deliver(&TrackerWorker::on_scene, scene_message(1));
  EXPECT_EQ(worker.step(), 1);
}

// ---- the frame's end (frame_done_t) ---------------------------------------------------------------

frame_done_object_t entry_for(std::int32_t object_id, std::int32_t worker_id, std::int64_t instance,
                              std::int32_t version) {
  frame_done_object_t e{};
  e.object_id = object_id;
  e.worker_id = worker_id;
  e.worker_instance = instance;
  e.version = version;
  pose_to_arrays(kStart, e.position, e.orientation);
  return e;
}

frame_done_t frame_done_of(std::int64_t seq, std::vector<frame_done_object_t> objects) {
  frame_done_t msg{};
  msg.frame_seq = seq;
  msg.objects = std::move(objects);
  msg.num_objects = static_cast<std::int32_t>(msg.objects.size());
  return msg;
}

// The entry of the object held, at the version held, stands for that model of its frame: the next
// scene goes at once, with what the entry says the other objects claim left out.
TEST(TrackerWorkerFrameDone, AnEntryWithTheVersionHeldStandsForTheModelOfItsFrame) {
  TrackerConfig c = TrackerWorkerTest::config();
  c.step.exclude_claimed_radius = 0.01f;
  RecordingTrackerSink sink;
  MalformedCounter malformed;
  const auto now = std::chrono::steady_clock::time_point{std::chrono::seconds(100)};
  TrackerWorker worker{c, {4, 444, "host-a"}, sink, malformed, [now] { return now; }};
  auto deliver_to = [&worker](auto handler, const auto& message) {
    Bytes bytes = encode(message);
    const lcm::ReceiveBuffer buffer{bytes.data(), static_cast<std::uint32_t>(bytes.size()), 0};
    (worker.*handler)(&buffer, "TEST");
  };
  const scene_cloud_t scene = scene_message(1);
  deliver_to(&TrackerWorker::on_model, model_for(7, 4, 444, 0));
  deliver_to(&TrackerWorker::on_scene, scene);
  ASSERT_EQ(worker.step(), 1);
  EXPECT_EQ(sink.estimates[0].num_hypothesis_points, scene.num_points);
  frame_done_object_t mine = entry_for(7, 4, 444, 1);
  std::vector<Eigen::Vector3f> claimed;
  for (std::size_t i = 0; i < scene.x.size(); ++i) claimed.emplace_back(scene.x[i], scene.y[i], scene.z[i]);
  claimed_to_message(claimed, mine);
  deliver_to(&TrackerWorker::on_frame_done, frame_done_of(1, {entry_for(2, 1, 111, 5), mine}));
  scene_cloud_t next = scene_message(2);
  next.x = scene.x, next.y = scene.y, next.z = scene.z;
  deliver_to(&TrackerWorker::on_scene, next);
  ASSERT_EQ(worker.step(), 1);
  ASSERT_EQ(sink.estimates.size(), 2u);
  EXPECT_EQ(sink.estimates[1].num_hypothesis_points, 0);
  EXPECT_EQ(worker.tracker().grid_builds(), 1);  // the model kept
  EXPECT_EQ(malformed.total(), 0);
}

// The entry lists a version this worker does not hold (the model was lost): the next scene waits,
// the heartbeat shows the worker behind, and the model, once it comes, releases the scene.
TEST_F(TrackerWorkerTest, AnEntryWithAVersionNotHeldLeavesTheNextSceneWaitingForTheModel) {
  deliver(&TrackerWorker::on_model, model_for(7, 4, 444, 0));
  deliver(&TrackerWorker::on_scene, scene_message(1));
  ASSERT_EQ(worker.step(), 1);
  deliver(&TrackerWorker::on_frame_done, frame_done_of(1, {entry_for(7, 4, 444, 2)}));
  deliver(&TrackerWorker::on_scene, scene_message(2));
  now += std::chrono::milliseconds(150);
  EXPECT_EQ(worker.step(), 0);
  EXPECT_EQ(sink.heartbeats.back().last_frame_seq, 1);
  EXPECT_EQ(sink.heartbeats.back().object_id, 7);
  object_model_t version2 = model_for(7, 4, 444, 1);
  version2.version = 2;
  deliver(&TrackerWorker::on_model, version2);
  EXPECT_EQ(worker.tracker().model_version(), 2);
  EXPECT_EQ(worker.step(), 1);
  EXPECT_EQ(sink.estimates.back().frame_seq, 2);
  EXPECT_EQ(malformed.total(), 0);
}

// Version 2 of kModel: grown by a part (the merger's growth), one point of the first view dropped.
ManagedObject version2_object() {
  ManagedObject object;
  object.id = 7;
  object.version = 2;
  object.pose = kStart;
  for (std::size_t i = 1; i < kModel.cloud.size(); ++i) {
    object.model.cloud.push_back(kModel.cloud.positions[i], kModel.cloud.colors[i]);
  }
  for (int i = 0; i < 20; ++i) {
    object.model.cloud.push_back(Eigen::Vector3f(0.001f * static_cast<float>(i), 0.f, 0.06f), Rgb8{1, 2, 3});
  }
  return object;
}

// The merger sends version 2 as an edit of version 1, which this worker holds: it holds the same model as
// from the whole message, the frame's end releases the next scene, and the estimate is the one the whole
// model gives.
TEST_F(TrackerWorkerTest, AnEditOfTheVersionHeldGivesTheWholeModelsEstimateOnceItsFrameEnds) {
  const ManagedObject object = version2_object();
  ModelDiffer differ;
  const HeldModel held{1, kModel.cloud};
  const object_model_t edit = model_message(object, 4, 444, 1, {}, 0, &held, differ);
  ASSERT_TRUE(edit.is_delta);
  ASSERT_EQ(edit.num_points, 20);
  const object_model_t whole = model_message(object, 4, 444, 1, {}, 0);
  ASSERT_FALSE(whole.is_delta);
  std::vector<tracker_estimate_t> estimates;
  for (const object_model_t* sent : {&edit, &whole}) {
    RecordingTrackerSink out;
    TrackerWorker w{config(), {4, 444, "host-a"}, out, malformed, [this] { return now; }};
    const auto feed = [&w](auto handler, const auto& message) {
      Bytes bytes = encode(message);
      const lcm::ReceiveBuffer buffer{bytes.data(), static_cast<std::uint32_t>(bytes.size()), 0};
      (w.*handler)(&buffer, "TEST");
    };
    feed(&TrackerWorker::on_model, model_for(7, 4, 444, 0));
    feed(&TrackerWorker::on_scene, scene_message(1));
    ASSERT_EQ(w.step(), 1);
    feed(&TrackerWorker::on_model, *sent);
    EXPECT_EQ(w.tracker().model_version(), 2);
    ASSERT_EQ(w.tracker().model().cloud.size(), object.model.cloud.size());
    for (std::size_t i = 0; i < object.model.cloud.size(); ++i) {
      ASSERT_EQ(w.tracker().model().cloud.positions[i], object.model.cloud.positions[i]) << i;
    }
    feed(&TrackerWorker::on_scene, scene_message(2));
    if (sent == &edit) {
      EXPECT_EQ(w.step(), 0);  // an edit leaves the release to its frame's end
    }
    feed(&TrackerWorker::on_frame_done, frame_done_of(1, {entry_for(7, 4, 444, 2)}));
    ASSERT_EQ(w.step(), 1);
    estimates.push_back(out.estimates.back());
    EXPECT_EQ(w.model_gaps(), 0);
  }
  EXPECT_EQ(estimates[0].frame_seq, 2);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(estimates[0].position[i], estimates[1].position[i]);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(estimates[0].orientation[i], estimates[1].orientation[i]);
  EXPECT_EQ(malformed.total(), 0);
}

// An edit of a version this worker does not hold (the one before was lost) is not taken, nor counted as
// malformed: the worker says at once that it is behind, the scenes wait, and the whole model, sent
// again, releases them.
TEST_F(TrackerWorkerTest, AnEditOfAVersionNotHeldIsNotTakenAndAHeartbeatSaysTheWorkerIsBehind) {
  deliver(&TrackerWorker::on_model, model_for(7, 4, 444, 0));
  deliver(&TrackerWorker::on_scene, scene_message(1));
  ASSERT_EQ(worker.step(), 1);
  const std::size_t heartbeats = sink.heartbeats.size();
  ManagedObject object = version2_object();
  object.version = 3;
  ModelDiffer differ;
  const HeldModel lost{2, kModel.cloud};  // version 2 never arrived
  const object_model_t edit = model_message(object, 4, 444, 2, {}, 0, &lost, differ);
  ASSERT_TRUE(edit.is_delta);
  deliver(&TrackerWorker::on_model, edit);
  EXPECT_EQ(worker.tracker().model_version(), 1);
  EXPECT_EQ(worker.model_gaps(), 1);
  EXPECT_EQ(malformed.total(), 0);
  deliver(&TrackerWorker::on_frame_done, frame_done_of(2, {entry_for(7, 4, 444, 3)}));
  deliver(&TrackerWorker::on_scene, scene_message(3));
  EXPECT_EQ(worker.step(), 0);  // at the same instant: no heartbeat would be due
  ASSERT_EQ(sink.heartbeats.size(), heartbeats + 1);
  EXPECT_EQ(sink.heartbeats.back().last_frame_seq, 1);
  deliver(&TrackerWorker::on_model, model_message(object, 4, 444, 2, {}, 0));
  EXPECT_EQ(worker.tracker().model_version(), 3);
  EXPECT_EQ(worker.step(), 1);
  EXPECT_EQ(sink.estimates.back().frame_seq, 3);
  // A forged edit of the version held (runs that do not add up) is malformed, and changes nothing.
  object_model_t forged = model_message(object, 4, 444, 3, {}, 0, &lost, differ);
  forged.base_version = 3;
  forged.version = 4;
  forged.frame_seq = 3;
  deliver(&TrackerWorker::on_model, forged);
  EXPECT_EQ(worker.tracker().model_version(), 3);
  EXPECT_EQ(malformed.total(), 1);
}

TEST_F(TrackerWorkerTest, AFrameEndGivingTheObjectToAnotherOrNotListingItTakesItAway) {
  deliver(&TrackerWorker::on_model, model_for(7, 4, 444, 0));
  ASSERT_TRUE(worker.tracker().has_object());
  deliver(&TrackerWorker::on_frame_done, frame_done_of(1, {entry_for(7, 4, 444, 1)}));
  EXPECT_TRUE(worker.tracker().has_object());
  deliver(&TrackerWorker::on_frame_done, frame_done_of(2, {entry_for(7, 4, 555, 1)}));  // worker 4 in another process
  EXPECT_FALSE(worker.tracker().has_object());
  deliver(&TrackerWorker::on_model, model_for(7, 4, 444, 3));
  ASSERT_TRUE(worker.tracker().has_object());
  deliver(&TrackerWorker::on_frame_done, frame_done_of(4, {entry_for(8, 4, 444, 1)}));  // retired; 8 not held
  EXPECT_FALSE(worker.tracker().has_object());
  // Scenes of finished frames are not tracked once an object comes.
  deliver(&TrackerWorker::on_scene, scene_message(4));
  deliver(&TrackerWorker::on_model, model_for(8, 4, 444, 4));
  EXPECT_EQ(worker.step(), 0);
  EXPECT_EQ(malformed.total(), 0);
}

TEST_F(TrackerWorkerTest, AFrameEndCarryingTheHiddenObjectMovesTheFilter) {
  deliver(&TrackerWorker::on_model, model_for(7, 4, 444, 0));
  deliver(&TrackerWorker::on_scene, scene_message(1));
  ASSERT_EQ(worker.step(), 1);
  const Pose tracked = worker.tracker().filter().estimate();
  deliver(&TrackerWorker::on_frame_done, frame_done_of(1, {entry_for(7, 4, 444, 1)}));  // kStart: not carried, ignored
  EXPECT_EQ(worker.tracker().filter().estimate().translation, tracked.translation);
  frame_done_object_t carried = entry_for(7, 4, 444, 1);
  Pose away = kStart;
  away.translation += Eigen::Vector3f(0.04f, -0.01f, 0.02f);
  pose_to_arrays(away, carried.position, carried.orientation);
  carried.carried_by = 3;
  deliver(&TrackerWorker::on_frame_done, frame_done_of(2, {carried}));
  EXPECT_LT((worker.tracker().filter().estimate().translation - away.translation).norm(), 1e-6f);
  EXPECT_EQ(malformed.total(), 0);
}

TEST_F(TrackerWorkerTest, MalformedFrameEndsAreCountedAndChangeNothing) {
  deliver(&TrackerWorker::on_model, model_for(7, 4, 444, 0));
  Bytes truncated = encode(frame_done_of(1, {entry_for(7, 4, 444, 1)}));
  truncated.resize(truncated.size() - 3);
  const lcm::ReceiveBuffer half{truncated.data(), static_cast<std::uint32_t>(truncated.size()), 0};
  worker.on_frame_done(&half, "MFOT_FRAME_DONE");
  deliver(&TrackerWorker::on_frame_done, frame_done_of(-5, {entry_for(7, 4, 444, 1)}));
  frame_done_object_t bad_claim = entry_for(7, 4, 444, 1);
  claimed_to_message(std::vector<Eigen::Vector3f>{{0.f, std::nanf(""), 1.f}}, bad_claim);
  deliver(&TrackerWorker::on_frame_done, frame_done_of(1, {bad_claim}));
  frame_done_object_t bad_pose = entry_for(7, 4, 444, 1);
  bad_pose.orientation[0] = 3.0;
  deliver(&TrackerWorker::on_frame_done, frame_done_of(1, {bad_pose}));
  EXPECT_EQ(malformed.total(), 4);
  EXPECT_TRUE(worker.tracker().has_object());
  // None of them counted as frame 1's model: scene 2 waits for it.
  deliver(&TrackerWorker::on_scene, scene_message(2));
  EXPECT_EQ(worker.step(), 0);
  deliver(&TrackerWorker::on_frame_done, frame_done_of(1, {entry_for(7, 4, 444, 1)}));
  EXPECT_EQ(worker.step(), 1);
}

}  // namespace
TEST_F(TrackerWorkerTest, AnswersARestartedMergersRequestForTheObjectItHoldsOnly) {
  object_model_t request{};
  request.worker_id = 4;
  request.worker_instance = 444;
  request.object_id = 7;
  request.orientation[0] = 1;
  deliver(&TrackerWorker::on_model_request, request);
  EXPECT_TRUE(sink.reports.empty());  // holds nothing
  deliver(&TrackerWorker::on_model, model_for(7, 4, 444, 0));
  deliver(&TrackerWorker::on_scene, scene_message(1));
  ASSERT_EQ(worker.step(), 1);
  // Another object, another process under this id, or a request carrying points: no answer.
  object_model_t other = request;
  other.object_id = 8;
  deliver(&TrackerWorker::on_model_request, other);
  other = request;
  other.worker_instance = 555;
  deliver(&TrackerWorker::on_model_request, other);
  EXPECT_TRUE(sink.reports.empty());
  other = request;
  model_to_message(kModel, other);
  deliver(&TrackerWorker::on_model_request, other);
  EXPECT_TRUE(sink.reports.empty());
  EXPECT_EQ(malformed.total(), 1);
  deliver(&TrackerWorker::on_model_request, request);
  ASSERT_EQ(sink.reports.size(), 1u);
  const object_model_t& report = sink.reports[0];
  EXPECT_EQ(report.object_id, 7);
  EXPECT_EQ(report.worker_id, 4);
  EXPECT_EQ(report.worker_instance, 444);
  EXPECT_EQ(report.version, 1);
  EXPECT_EQ(report.frame_seq, 1);
  EXPECT_EQ(report.num_points, static_cast<std::int32_t>(kModel.cloud.size()));
  // Its last pose is its estimate of frame 1.
  EXPECT_DOUBLE_EQ(report.position[0], sink.estimates.back().position[0]);
  EXPECT_DOUBLE_EQ(report.orientation[0], sink.estimates.back().orientation[0]);
}

}  // namespace mfot::service
