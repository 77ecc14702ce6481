// The merger's protocol engine without LCM: WorkerPool (registry, liveness, assignment),
// FrameAssembler (open frames, estimates, timeouts, re-sends) and MergerCore around
// ObjectManager, driven with encoded messages and a clock moved by hand.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "encoded_message.hpp"
#include "mfot/heartbeat_t.hpp"
#include "mfot/scene_cloud_t.hpp"
#include "mfot/service/frame_assembler.hpp"
#include "mfot/service/merger_core.hpp"
#include "mfot/service/merger_messages.hpp"
#include "mfot/service/worker_pool.hpp"
#include "mfot/tracker_estimate_t.hpp"
#include "recording_merger_sink.hpp"

namespace mfot::service {
namespace {

using namespace std::chrono_literals;
using testing::ManualClock;
using testing::RecordingSink;
using testing::SentModel;
using Clock = std::chrono::steady_clock;

const Clock::time_point kT0{std::chrono::seconds(1000)};
bool always_exists(std::int32_t) { return true; }

// A heartbeat of worker `worker` (process instance `instance` on host `host`).
WorkerPool::Heartbeat beat(std::int32_t worker, std::int32_t held, std::int64_t last_seq, std::int64_t instance = 1,
                           const std::string& host = "host-a") {
  return {worker, instance, host, held, last_seq};
}

// ---- WorkerPool ---------------------------------------------------------------------------------

TEST(WorkerPool, ObjectsGoToTheIdleWorkerWithTheLowestId) {
  WorkerPool pool(WorkerPoolOptions{});
  pool.heartbeat(beat(7, -1, -1), kT0, always_exists);
  pool.heartbeat(beat(3, -1, -1), kT0, always_exists);
  const std::vector<std::int32_t> objects{1, 2, 5};
  const auto assigned = pool.assign(objects, kT0);
  ASSERT_EQ(assigned.size(), 2u);  // three objects, two workers: object 5 waits
  EXPECT_EQ(assigned[0].object_id, 1);
  EXPECT_EQ(assigned[0].worker_id, 3);
  EXPECT_EQ(assigned[1].object_id, 2);
  EXPECT_EQ(assigned[1].worker_id, 7);
  EXPECT_FALSE(pool.owner(5));
  EXPECT_TRUE(pool.owns(3, 1));
  EXPECT_FALSE(pool.owns(7, 1));
  EXPECT_TRUE(pool.assign(objects, kT0).empty());  // nothing changes while they live
}

TEST(WorkerPool, ObjectsSpreadOverTheHostsOfTheGroup) {
  WorkerPool pool(WorkerPoolOptions{});
  for (std::int32_t id : {0, 1, 2}) pool.heartbeat(beat(id, -1, -1, 10 + id, "host-a"), kT0, always_exists);
  for (std::int32_t id : {500, 501}) pool.heartbeat(beat(id, -1, -1, 10 + id, "host-b"), kT0, always_exists);
  const std::vector<std::int32_t> objects{1, 2, 3, 4};
  const auto assigned = pool.assign(objects, kT0);
  ASSERT_EQ(assigned.size(), 4u);
  std::map<std::string, int> per_host;
  for (const auto& a : assigned) ++per_host[pool.workers().at(a.worker_id).host];
  EXPECT_EQ(per_host["host-a"], 2);
  EXPECT_EQ(per_host["host-b"], 2);
  EXPECT_EQ(assigned[0].worker_id, 0);    // a tie: the lowest id
  EXPECT_EQ(assigned[1].worker_id, 500);  // then the host holding none
  // Host b is lost (host a's workers keep heartbeating): its two objects are freed; host a's one
  // idle worker takes the first, the other waits for a worker.
  const std::map<std::int32_t, std::int32_t> held{{0, 1}, {1, 3}, {2, -1}};  // as assigned above
  for (const auto& [id, object] : held)
    pool.heartbeat(beat(id, object, -1, 10 + id, "host-a"), kT0 + 1000ms, always_exists);
  EXPECT_EQ(pool.expire(kT0 + 1500ms), (std::vector<std::int32_t>{500, 501}));
  const auto moved = pool.assign(objects, kT0 + 1500ms);
  ASSERT_EQ(moved.size(), 1u);
  EXPECT_EQ(moved[0].worker_id, 2);
  EXPECT_EQ(pool.owners().size(), 3u);
}

TEST(WorkerPool, ASilentWorkerIsDeclaredDeadAndItsObjectGoesToAnother) {
  WorkerPool pool(WorkerPoolOptions{1000ms, 200ms});
  pool.heartbeat(beat(0, -1, -1), kT0, always_exists);
  const std::vector<std::int32_t> objects{4};
  ASSERT_EQ(pool.assign(objects, kT0).size(), 1u);
  pool.note_progress(4, 10);
  pool.heartbeat(beat(1, -1, -1), kT0 + 900ms, always_exists);
  EXPECT_TRUE(pool.expire(kT0 + 1000ms).empty());  // exactly the timeout: still alive
  const auto dead = pool.expire(kT0 + 1001ms);
  ASSERT_EQ(dead, std::vector<std::int32_t>{0});
  EXPECT_FALSE(pool.owner(4));
  EXPECT_FALSE(pool.progress(4));  // the new owner's progress starts afresh
  EXPECT_EQ(pool.alive_count(), 1);
  const auto reassigned = pool.assign(objects, kT0 + 1001ms);
  ASSERT_EQ(reassigned.size(), 1u);
  EXPECT_EQ(reassigned[0].worker_id, 1);
  // The dead worker comes back idle, and takes nothing from the live owner.
  pool.heartbeat(beat(0, 4, 10), kT0 + 1500ms, always_exists);
  EXPECT_EQ(pool.alive_count(), 2);
  EXPECT_TRUE(pool.owns(1, 4));
}

TEST(WorkerPool, AHeartbeatThatDisagreesIsCorrectedOnceTheModelHadTimeToArrive) {
  WorkerPool pool(WorkerPoolOptions{1000ms, 200ms});
  pool.heartbeat(beat(0, -1, -1), kT0, always_exists);
  const std::vector<std::int32_t> objects{1};
  pool.assign(objects, kT0);
  // Still idle 100 ms after the assignment: the model may be on its way.
  EXPECT_TRUE(pool.heartbeat(beat(0, -1, -1), kT0 + 100ms, always_exists).corrections.empty());
  // 300 ms after: it was lost; send it again (once per in-flight period).
  auto corrections = pool.heartbeat(beat(0, -1, -1), kT0 + 300ms, always_exists).corrections;
  ASSERT_EQ(corrections.size(), 1u);
  EXPECT_EQ(corrections[0].kind, WorkerPool::Correction::Kind::kSendModel);
  EXPECT_EQ(corrections[0].object_id, 1);
  EXPECT_EQ(corrections[0].worker_id, 0);
  EXPECT_TRUE(pool.heartbeat(beat(0, -1, -1), kT0 + 400ms, always_exists).corrections.empty());
  // Holding its object: progress is noted.
  EXPECT_TRUE(pool.heartbeat(beat(0, 1, 42), kT0 + 450ms, always_exists).corrections.empty());
  EXPECT_EQ(pool.progress(1), 42);
}

TEST(WorkerPool, AWorkerHoldingAnotherOwnersOrAMissingObjectIsTold) {
  WorkerPool pool(WorkerPoolOptions{1000ms, 200ms});
  pool.heartbeat(beat(0, -1, -1), kT0, always_exists);
  pool.heartbeat(beat(1, -1, -1), kT0, always_exists);
  const std::vector<std::int32_t> objects{1};
  pool.assign(objects, kT0);  // worker 0 owns object 1
  // Worker 1 still holds object 1 (it missed the move): told who owns it.
  auto told = pool.heartbeat(beat(1, 1, 5), kT0 + 300ms, always_exists).corrections;
  ASSERT_EQ(told.size(), 1u);
  EXPECT_EQ(told[0].kind, WorkerPool::Correction::Kind::kSendModel);
  EXPECT_EQ(told[0].object_id, 1);
  EXPECT_EQ(told[0].worker_id, 0);
  EXPECT_FALSE(pool.progress(1));  // a non-owner's progress does not count
  // Worker 1 holds object 9, which does not exist (a merger restart): retire it.
  told = pool.heartbeat(beat(1, 9, 5), kT0 + 600ms, [](std::int32_t id) { return id == 1; }).corrections;
  ASSERT_EQ(told.size(), 1u);
  EXPECT_EQ(told[0].kind, WorkerPool::Correction::Kind::kRetire);
  EXPECT_EQ(told[0].object_id, 9);
}

TEST(WorkerPool, AReleasedObjectFreesItsWorker) {
  WorkerPool pool(WorkerPoolOptions{});
  pool.heartbeat(beat(0, -1, -1), kT0, always_exists);
  std::vector<std::int32_t> objects{1};
  pool.assign(objects, kT0);
  pool.release(1, kT0);
  EXPECT_FALSE(pool.owner(1));
  objects = {2};
  const auto assigned = pool.assign(objects, kT0);
  ASSERT_EQ(assigned.size(), 1u);
  EXPECT_EQ(assigned[0].worker_id, 0);
}

TEST(WorkerPool, TwoProcessesUnderOneWorkerIdClashAndTheNewerIsIgnored) {
  WorkerPool pool(WorkerPoolOptions{1000ms, 200ms, 250ms});
  pool.heartbeat(beat(4, -1, -1, 11, "host-a"), kT0, always_exists);
  const std::vector<std::int32_t> objects{1};
  pool.assign(objects, kT0);
  // A second process on another host starts as worker 4: it waits ...
  auto reply = pool.heartbeat(beat(4, -1, -1, 22, "host-b"), kT0 + 50ms, always_exists);
  EXPECT_FALSE(reply.clash);
  EXPECT_TRUE(reply.corrections.empty());
  // ... and when the first heartbeats again, both are alive: a clash, said, never shared.
  reply = pool.heartbeat(beat(4, 1, 3, 11, "host-a"), kT0 + 100ms, always_exists);
  ASSERT_TRUE(reply.clash);
  EXPECT_NE(reply.clash->find("host-b"), std::string::npos) << *reply.clash;
  reply = pool.heartbeat(beat(4, -1, -1, 22, "host-b"), kT0 + 150ms, always_exists);
  EXPECT_TRUE(reply.clash);
  EXPECT_TRUE(reply.corrections.empty());  // the newcomer is not sent the object
  EXPECT_EQ(pool.instance_of(4), 11);
  EXPECT_TRUE(pool.owns(4, 1));
  EXPECT_EQ(pool.workers().at(4).host, "host-a");
  EXPECT_GE(pool.clashes(), 2);
}

TEST(WorkerPool, ARestartedWorkerTakesItsIdBackOnceTheOldProcessIsSilent) {
  WorkerPool pool(WorkerPoolOptions{1000ms, 200ms, 250ms});
  pool.heartbeat(beat(4, -1, -1, 11), kT0, always_exists);
  const std::vector<std::int32_t> objects{1};
  pool.assign(objects, kT0);
  pool.heartbeat(beat(4, 1, 5, 11), kT0 + 100ms, always_exists);
  // The process is restarted: the new one is heard 50 ms after the old one's last heartbeat ...
  EXPECT_FALSE(pool.heartbeat(beat(4, -1, -1, 33), kT0 + 150ms, always_exists).clash);
  EXPECT_EQ(pool.instance_of(4), 11);
  // ... and takes the id over once the old one has been silent past the takeover silence; it
  // keeps the object and is sent its model again (it holds nothing).
  const auto reply = pool.heartbeat(beat(4, -1, -1, 33), kT0 + 400ms, always_exists);
  EXPECT_FALSE(reply.clash);
  EXPECT_EQ(pool.instance_of(4), 33);
  EXPECT_TRUE(pool.owns(4, 1));
  ASSERT_EQ(reply.corrections.size(), 1u);
  EXPECT_EQ(reply.corrections[0].object_id, 1);
  EXPECT_EQ(pool.clashes(), 0);
}

TEST(WorkerPool, OptionsOutOfRangeAreRefused) {
  EXPECT_THROW(WorkerPool(WorkerPoolOptions{50ms, 10ms}), std::invalid_argument);
  EXPECT_THROW(WorkerPool(WorkerPoolOptions{1000ms, 2000ms}), std::invalid_argument);
  EXPECT_THROW(WorkerPool(WorkerPoolOptions{1000ms, 200ms, 0ms}), std::invalid_argument);
}

// ---- FrameAssembler ----------------------------------------------------------------------------

Scene scene_of(std::int64_t seq) {
  Scene scene;
  scene.frame_seq = seq;
  return scene;
}

ObjectEstimate estimate_at(float x) {
  ObjectEstimate e;
  e.pose.translation = Eigen::Vector3f(x, 0.f, 1.f);
  e.confidence = 0.5f;
  return e;
}

struct AssemblerTest : ::testing::Test {
  FrameAssemblerOptions options() {
    FrameAssemblerOptions o;
    o.estimate_timeout = 500ms;
    return o;
  }
  // Workers 0 and 1 own objects 1 and 2.
  void SetUp() override {
    pool.heartbeat(beat(0, -1, -1), kT0, always_exists);
    pool.heartbeat(beat(1, -1, -1), kT0, always_exists);
    const std::vector<std::int32_t> objects{1, 2};
    pool.assign(objects, kT0);
  }
  WorkerPool pool{WorkerPoolOptions{}};
};

TEST_F(AssemblerTest, ScenesQueueInOrderAndRepeatsOrLateOnesAreRefused) {
  FrameAssembler frames(options());
  EXPECT_EQ(frames.add_scene(scene_of(2), {}, kT0), FrameAssembler::Arrival::kQueued);
  EXPECT_EQ(frames.add_scene(scene_of(1), {}, kT0), FrameAssembler::Arrival::kQueued);
  EXPECT_EQ(frames.add_scene(scene_of(2), {}, kT0), FrameAssembler::Arrival::kRepeated);
  EXPECT_EQ(frames.open_frames(), 2u);
  const auto later = kT0 + 501ms;  // no estimates: both time out
  ASSERT_TRUE(frames.poll(later, pool).due);
  EXPECT_EQ(frames.take(pool).scene.frame_seq, 1);
  frames.finished(later);
  EXPECT_FALSE(frames.poll(later, pool).due);  // the timeout of frame 2 runs from frame 1's finish
  ASSERT_TRUE(frames.poll(later + 501ms, pool).due);
  EXPECT_EQ(frames.take(pool).scene.frame_seq, 2);
  EXPECT_EQ(frames.add_scene(scene_of(2), {}, kT0), FrameAssembler::Arrival::kLate);
  EXPECT_FALSE(frames.add_estimate(2, 1, estimate_at(0.f)));  // too late as well
  // Far older than the last finished frame: a restarted source.
  EXPECT_EQ(frames.add_scene(scene_of(2 + 0), {}, kT0), FrameAssembler::Arrival::kLate);
  FrameAssembler restarted(options());
  restarted.add_scene(scene_of(500), {}, kT0);
  restarted.poll(kT0 + 501ms, pool);
  restarted.take(pool);
  EXPECT_EQ(restarted.add_scene(scene_of(3), {}, kT0), FrameAssembler::Arrival::kNewSequence);
  EXPECT_EQ(restarted.last_finished_seq(), -1);
}

TEST_F(AssemblerTest, AFrameIsDueWhenEveryOwnerAnsweredAndCarriesOnlyTheOwnersEstimates) {
  FrameAssembler frames(options());
  frames.add_scene(scene_of(0), {}, kT0);
  EXPECT_TRUE(frames.add_estimate(0, 1, estimate_at(0.1f)));
  EXPECT_FALSE(frames.poll(kT0 + 10ms, pool).due);  // object 2's owner has not answered
  frames.add_estimate(0, 2, estimate_at(0.2f));
  frames.add_estimate(0, 9, estimate_at(0.9f));  // no owner (the caller filters senders; the owner may be gone)
  ASSERT_TRUE(frames.poll(kT0 + 10ms, pool).due);
  const auto due = frames.take(pool);
  ASSERT_EQ(due.estimates.size(), 2u);
  EXPECT_FLOAT_EQ(due.estimates.at(1).pose.translation.x(), 0.1f);
  EXPECT_FLOAT_EQ(due.estimates.at(2).pose.translation.x(), 0.2f);
}

TEST_F(AssemblerTest, AnOwnerThatFinishedTheFrameWithoutAnEstimateIsNotWaitedFor) {
  FrameAssembler frames(options());
  frames.add_scene(scene_of(4), {}, kT0);
  frames.add_estimate(4, 1, estimate_at(0.1f));
  pool.note_progress(2, 4);  // object 2's owner skipped frame 4
  EXPECT_TRUE(frames.poll(kT0 + 1ms, pool).due);
}

TEST_F(AssemblerTest, AWorkerThatLostTheSceneGetsItAgainAFewTimesAtMost) {
  FrameAssembler frames(options());
  const std::vector<std::uint8_t> bytes{1, 2, 3};
  frames.add_scene(scene_of(0), bytes, kT0);
  frames.add_estimate(0, 1, estimate_at(0.1f));
  // Worker 1 heartbeats 300 ms after the scene went out without having finished frame 0.
  pool.heartbeat(beat(1, 2, -1), kT0 + 300ms, always_exists);
  auto poll = frames.poll(kT0 + 300ms, pool);
  EXPECT_FALSE(poll.due);
  ASSERT_EQ(poll.resend_models.size(), 1u);
  EXPECT_EQ(poll.resend_models[0].object_id, 2);
  EXPECT_EQ(poll.resend_models[0].worker_id, 1);
  ASSERT_NE(poll.resend_scene, nullptr);
  EXPECT_EQ(*poll.resend_scene, bytes);
  // Not again before the re-send interval, and not again once it answered.
  EXPECT_TRUE(frames.poll(kT0 + 350ms, pool).resend_models.empty());
  FrameAssemblerOptions o = options();
  o.estimate_timeout = 100000ms;
  FrameAssembler patient(o);
  patient.add_scene(scene_of(0), bytes, kT0);
  int resends = 0;
  for (int i = 1; i <= 20; ++i) {
    const auto now = kT0 + i * 300ms;
    pool.heartbeat(beat(0, 1, -1), now, always_exists);
    pool.heartbeat(beat(1, 2, -1), now, always_exists);
    if (!patient.poll(now, pool).resend_models.empty()) ++resends;
  }
  EXPECT_EQ(resends, o.max_resends);
}

TEST_F(AssemblerTest, TheFirstFrameWaitsForTheExpectedWorkersUpToTheStartupTimeout) {
  FrameAssemblerOptions o = options();
  o.expected_workers = 3;  // two are alive
  o.startup_timeout = 2000ms;
  FrameAssembler frames(o);
  frames.add_scene(scene_of(0), {}, kT0);
  pool.note_progress(1, 0);
  pool.note_progress(2, 0);
  EXPECT_FALSE(frames.poll(kT0 + 1999ms, pool).due);
  EXPECT_TRUE(frames.poll(kT0 + 2001ms, pool).due);
}

// ---- MergerCore ---------------------------------------------------------------------------------

using testing::Bytes;
using testing::encode;

// A 12 x 12 x 2 block of 5 mm voxels around (x, 0, 0.9), one cluster.
scene_cloud_t block_scene(std::int64_t seq, float x) {
  scene_cloud_t msg{};
  msg.frame_seq = seq;
  msg.capture_utime = 1000 * seq;
  msg.width = 640;
  msg.height = 480;
  msg.fx = msg.fy = 525.0f;
  msg.cx = 320.f;
  msg.cy = 240.f;
  msg.voxel_size = 0.005f;
  msg.plane[1] = 1.f;
  msg.num_clusters = 1;
  msg.num_standing_clusters = 1;
  for (int i = 0; i < 12; ++i) {
    for (int j = 0; j < 12; ++j) {
      for (int k = 0; k < 2; ++k) {
        msg.x.push_back(x + 0.005f * static_cast<float>(i));
        msg.y.push_back(0.005f * static_cast<float>(j));
        msg.z.push_back(0.9f + 0.005f * static_cast<float>(k));
        msg.r.push_back(200);
        msg.g.push_back(30);
        msg.b.push_back(30);
        msg.u.push_back(static_cast<std::int16_t>(320 + i));
        msg.v.push_back(static_cast<std::int16_t>(240 + j));
        msg.cluster.push_back(0);
      }
    }
  }
  msg.num_points = static_cast<std::int32_t>(msg.x.size());
  return msg;
}

// block_scene's block and a second one (cluster 1) 1.5 cm to its right, from x + 0.075 m.
scene_cloud_t two_block_scene(std::int64_t seq, float x) {
  scene_cloud_t msg = block_scene(seq, x);
  const scene_cloud_t right = block_scene(seq, x + 0.075f);
  const auto n = right.x.size();
  for (std::size_t i = 0; i < n; ++i) {
    msg.x.push_back(right.x[i]);
    msg.y.push_back(right.y[i]);
    msg.z.push_back(right.z[i]);
    msg.r.push_back(30);
    msg.g.push_back(200);
    msg.b.push_back(30);
    msg.u.push_back(static_cast<std::int16_t>(right.u[i] + 20));
    msg.v.push_back(right.v[i]);
    msg.cluster.push_back(1);
  }
  msg.num_clusters = 2;
  msg.num_standing_clusters = 2;
  msg.num_points = static_cast<std::int32_t>(msg.x.size());
  return msg;
}

heartbeat_t heartbeat_of(std::int32_t worker, std::int32_t object, std::int64_t last_seq) {
  heartbeat_t msg{};
  msg.worker_id = worker;
  msg.instance = 100 + worker;
  msg.host = "host-a";
  msg.object_id = object;
  msg.last_frame_seq = last_seq;
  return msg;
}

tracker_estimate_t estimate_of(std::int64_t seq, std::int32_t object, std::int32_t worker, const Pose& pose) {
  tracker_estimate_t msg{};
  msg.frame_seq = seq;
  msg.object_id = object;
  msg.worker_id = worker;
  pose_to_arrays(pose, msg.position, msg.orientation);
  msg.confidence = 0.8f;
  return msg;
}

struct MergerCoreTest : ::testing::Test {
  MergerCoreOptions options() {
    MergerCoreOptions o;
    o.workers.worker_timeout = 1000ms;
    o.frames.estimate_timeout = 500ms;
    return o;
  }
  template <class T>
  void deliver(void (MergerCore::*handler)(const lcm::ReceiveBuffer*, const std::string&), const T& message) {
    Bytes bytes = encode(message);
    const lcm::ReceiveBuffer buffer{bytes.data(), static_cast<std::uint32_t>(bytes.size()), 0};
    (core.*handler)(&buffer, "TEST");
  }
  RecordingSink sink;
  MalformedCounter malformed;
  ManualClock clock;
  MergerCore core{options(), sink, malformed, clock.function()};
};

TEST_F(MergerCoreTest, AFrameWithoutObjectsCreatesThemAndHandsThemToWorkers) {
  deliver(&MergerCore::on_heartbeat, heartbeat_of(0, -1, -1));
  deliver(&MergerCore::on_scene, block_scene(0, 0.f));
  EXPECT_EQ(core.step(), 1);  // no owners yet: nothing to wait for
  ASSERT_EQ(sink.frames.size(), 1u);
  EXPECT_EQ(sink.frames[0].created, std::vector<std::int32_t>{1});
  ASSERT_EQ(sink.models.size(), 1u);
  EXPECT_EQ(sink.models[0].object_id, 1);
  EXPECT_EQ(sink.models[0].worker_id, 0);
  EXPECT_EQ(sink.models[0].worker_instance, 100);  // addressed to that worker's process
  EXPECT_EQ(sink.models[0].frame_seq, 0);
  EXPECT_TRUE(core.workers().owns(0, 1));

  // Frame 1 waits for its owner; a non-owner's estimate does not count.
  deliver(&MergerCore::on_scene, block_scene(1, 0.01f));
  EXPECT_EQ(core.step(), 0);
  Pose moved = sink.frames[0].poses.at(1);
  moved.translation.x() += 0.01f;
  deliver(&MergerCore::on_estimate, estimate_of(1, 1, 5, moved));
  EXPECT_EQ(core.step(), 0);
  deliver(&MergerCore::on_estimate, estimate_of(1, 1, 0, moved));
  EXPECT_EQ(core.step(), 1);
  ASSERT_EQ(sink.frames.size(), 2u);
  EXPECT_FALSE(sink.frames[1].stale.at(1));
  EXPECT_NEAR(sink.frames[1].poses.at(1).translation.x(), moved.translation.x(), 1e-6f);
  // Its owner got the model of frame 1 (the default model update changed it), before the frame's end.
  EXPECT_EQ(sink.models.back().frame_seq, 1);
  EXPECT_EQ(sink.models.back().worker_id, 0);
  EXPECT_EQ(sink.models.back().recipient, 0);
  ASSERT_EQ(sink.frame_dones.size(), 2u);
  EXPECT_EQ(sink.frame_dones[1].frame_seq, 1);
  ASSERT_EQ(sink.frame_dones[1].num_objects, 1);
  EXPECT_EQ(sink.frame_dones[1].objects[0].version, sink.models.back().version);
  EXPECT_FALSE(core.manager().objects().at(1).held);
  // A held estimate (the tracker saw nothing of it) reaches the manager as held.
  deliver(&MergerCore::on_scene, block_scene(2, 0.01f));
  tracker_estimate_t held = estimate_of(2, 1, 0, moved);
  held.held = true;
  deliver(&MergerCore::on_estimate, held);
  EXPECT_EQ(core.step(), 1);
  EXPECT_TRUE(core.manager().objects().at(1).held);
  EXPECT_EQ(malformed.total(), 0);
}

TEST_F(MergerCoreTest, EachModelCarriesWhatTheOtherObjectsClaimNearIt) {
  for (const float margin : {0.062f, 0.f}) {
    MergerCoreOptions o = options();
    o.claimed_margin = margin;
    RecordingSink claims;
    MergerCore claiming{o, claims, malformed, clock.function()};
    for (const std::int32_t worker : {0, 1}) {
      Bytes hb = encode(heartbeat_of(worker, -1, -1));
      const lcm::ReceiveBuffer buffer{hb.data(), static_cast<std::uint32_t>(hb.size()), 0};
      claiming.on_heartbeat(&buffer, "TEST");
    }
    Bytes scene = encode(two_block_scene(0, 0.f));
    const lcm::ReceiveBuffer buffer{scene.data(), static_cast<std::uint32_t>(scene.size()), 0};
    claiming.on_scene(&buffer, "TEST");
    EXPECT_EQ(claiming.step(), 1);
    ASSERT_EQ(claims.models.size(), 2u);
    for (const SentModel& model : claims.models) {
      SCOPED_TRACE(::testing::Message() << "object " << model.object_id << ", margin " << margin);
      if (margin == 0.f) {
        EXPECT_TRUE(model.claimed.empty());
        continue;
      }
      // The other block's columns within 6.2 cm of this block's box (9 of its 12), camera frame.
      EXPECT_EQ(model.claimed.size(), 9u * 12u * 2u);
      for (const Eigen::Vector3f& p : model.claimed) {
        if (model.object_id == 1)
          EXPECT_GT(p.x(), 0.07f);
        else
          EXPECT_LT(p.x(), 0.06f);
      }
    }
  }
}

// Without a model update (alpha 0) the model does not change: after its assignment it goes out
// again only when asked for; every frame's end lists the object with its owner and version, and
// what the owner's tracker needs beside the model. With alpha > 0 every frame changes the model:
// it goes out every frame, with the frame's end listing the version sent.
TEST_F(MergerCoreTest, AModelGoesOutOnlyWhenItChangesAndEveryFrameEndListsTheVersions) {
  for (const float alpha : {0.f, 0.5f}) {
    SCOPED_TRACE(::testing::Message() << "alpha " << alpha);
    MergerCoreOptions o = options();
    o.manager.model_update.alpha = alpha;
    o.claimed_margin = 0.062f;
    RecordingSink out;
    MergerCore merger{o, out, malformed, clock.function()};
    const auto feed = [&merger](auto handler, const auto& message) {
      Bytes bytes = encode(message);
      const lcm::ReceiveBuffer buffer{bytes.data(), static_cast<std::uint32_t>(bytes.size()), 0};
      (merger.*handler)(&buffer, "TEST");
    };
    feed(&MergerCore::on_heartbeat, heartbeat_of(0, -1, -1));
    feed(&MergerCore::on_heartbeat, heartbeat_of(1, -1, -1));
    feed(&MergerCore::on_scene, two_block_scene(0, 0.f));
    ASSERT_EQ(merger.step(), 1);
    ASSERT_EQ(out.models.size(), 2u);  // the assignments
    for (std::int64_t seq = 1; seq <= 3; ++seq) {
      const std::size_t models_before = out.models.size();
      feed(&MergerCore::on_scene, two_block_scene(seq, 0.f));
      for (const std::int32_t object : {1, 2}) {
        const std::int32_t owner = merger.workers().owner(object).value();
        feed(&MergerCore::on_estimate, estimate_of(seq, object, owner, merger.manager().objects().at(object).pose));
      }
      ASSERT_EQ(merger.step(), 1);
      ASSERT_EQ(out.frame_dones.size(), static_cast<std::size_t>(seq + 1));
      const frame_done_t& done = out.frame_dones.back();
      EXPECT_EQ(done.frame_seq, seq);
      ASSERT_EQ(done.num_objects, 2);
      ASSERT_EQ(done.objects.size(), 2u);
      for (const frame_done_object_t& entry : done.objects) {
        const ManagedObject& object = merger.manager().objects().at(entry.object_id);
        EXPECT_EQ(entry.version, object.version);
        EXPECT_EQ(entry.worker_id, merger.workers().owner(entry.object_id).value());
        EXPECT_EQ(entry.worker_instance, 100 + entry.worker_id);
        std::vector<Eigen::Vector3f> claimed;  // the other block's points near it, as a model carries them
        merger.manager().claimed_points(entry.object_id, o.claimed_margin, claimed);
        EXPECT_GT(claimed.size(), 100u);
        ASSERT_EQ(entry.num_claimed, static_cast<std::int32_t>(claimed.size()));
        EXPECT_EQ(entry.claimed_x[0], claimed[0].x());
        EXPECT_FLOAT_EQ(static_cast<float>(entry.position[0]), object.pose.translation.x());
      }
      if (alpha == 0.f) {
        EXPECT_EQ(out.models.size(), models_before);
        EXPECT_EQ(done.objects[0].version, out.models[0].version);
      } else {
        ASSERT_EQ(out.models.size(), models_before + 2);
        for (std::size_t k = models_before; k < out.models.size(); ++k) {
          EXPECT_EQ(out.models[k].frame_seq, seq);
          EXPECT_EQ(out.models[k].recipient, out.models[k].worker_id);
          EXPECT_EQ(out.models[k].version, merger.manager().objects().at(out.models[k].object_id).version);
          // It may go as an edit of the version its owner was sent last.
          std::int32_t sent_before = -1;
          for (std::size_t j = 0; j < k; ++j) {
            if (out.models[j].object_id == out.models[k].object_id) sent_before = out.models[j].version;
          }
          EXPECT_GE(sent_before, 0);
          EXPECT_EQ(out.models[k].held_version, sent_before);
        }
      }
    }
  }
}

// A tracker that lacks the model its frame's end lists falls behind; its heartbeat says so and the
// model goes out again (the frame assembler's re-send), on that worker's channel.
TEST_F(MergerCoreTest, AWorkerBehindGetsItsModelAgain) {
  MergerCoreOptions o = options();
  o.manager.model_update.alpha = 0.f;
  RecordingSink out;
  MergerCore merger{o, out, malformed, clock.function()};
  const auto feed = [&merger](auto handler, const auto& message) {
    Bytes bytes = encode(message);
    const lcm::ReceiveBuffer buffer{bytes.data(), static_cast<std::uint32_t>(bytes.size()), 0};
    (merger.*handler)(&buffer, "TEST");
  };
  feed(&MergerCore::on_heartbeat, heartbeat_of(0, -1, -1));
  feed(&MergerCore::on_scene, block_scene(0, 0.f));
  ASSERT_EQ(merger.step(), 1);
  feed(&MergerCore::on_scene, block_scene(1, 0.f));
  feed(&MergerCore::on_estimate, estimate_of(1, 1, 0, merger.manager().objects().at(1).pose));
  ASSERT_EQ(merger.step(), 1);
  ASSERT_EQ(out.models.size(), 1u);  // the assignment only
  // Frame 2's scene is out; well after it the worker still reports frame 1 as its last: it lacks
  // frame 1's model (its frame end was lost, or it held an older version than the frame end listed).
  feed(&MergerCore::on_scene, block_scene(2, 0.f));
  clock.advance(250ms);
  feed(&MergerCore::on_heartbeat, heartbeat_of(0, 1, 1));
  EXPECT_EQ(merger.step(), 0);
  ASSERT_EQ(out.models.size(), 2u);
  EXPECT_EQ(out.models[1].object_id, 1);
  EXPECT_EQ(out.models[1].frame_seq, 1);
  EXPECT_EQ(out.models[1].recipient, 0);
  EXPECT_EQ(out.models[1].held_version, -1);  // the whole model: the worker may lack any version
  EXPECT_EQ(out.models[0].held_version, -1);  // as on assignment
  EXPECT_EQ(out.resent_scenes.size(), 1u);
}

TEST_F(MergerCoreTest, AMissingEstimateLeavesThePoseStaleAfterTheTimeout) {
  deliver(&MergerCore::on_heartbeat, heartbeat_of(0, -1, -1));
  deliver(&MergerCore::on_scene, block_scene(0, 0.f));
  core.step();
  deliver(&MergerCore::on_scene, block_scene(1, 0.f));
  clock.advance(400ms);
  EXPECT_EQ(core.step(), 0);
  clock.advance(200ms);
  EXPECT_EQ(core.step(), 1);
  EXPECT_TRUE(sink.frames.back().stale.at(1));
}

TEST_F(MergerCoreTest, ADeadWorkersObjectMovesWithItsIdModelAndPoseToAnother) {
  deliver(&MergerCore::on_heartbeat, heartbeat_of(0, -1, -1));
  deliver(&MergerCore::on_scene, block_scene(0, 0.f));
  core.step();
  const SentModel first = sink.models.back();
  clock.advance(100ms);
  deliver(&MergerCore::on_heartbeat, heartbeat_of(1, -1, -1));  // a second worker joins, idle
  core.step();
  clock.advance(600ms);
  deliver(&MergerCore::on_heartbeat, heartbeat_of(1, -1, -1));
  core.step();
  EXPECT_TRUE(core.workers().owns(0, 1));
  clock.advance(500ms);  // worker 0 silent for 1.2 s
  deliver(&MergerCore::on_heartbeat, heartbeat_of(1, -1, -1));
  core.step();
  EXPECT_TRUE(core.workers().owns(1, 1));
  const SentModel moved = sink.models.back();
  EXPECT_EQ(moved.object_id, 1);
  EXPECT_EQ(moved.worker_id, 1);
  EXPECT_EQ(moved.model_points, first.model_points);
  EXPECT_TRUE(moved.pose.translation.isApprox(first.pose.translation));
}

TEST_F(MergerCoreTest, AWorkerHoldingAnUnknownObjectIsToldToRetireItAndItsIdIsNotReused) {
  deliver(&MergerCore::on_heartbeat, heartbeat_of(3, 7, 20));  // from before a merger restart
  clock.advance(100ms);
  deliver(&MergerCore::on_heartbeat, heartbeat_of(3, 7, 20));  // the retirement may be on its way
  ASSERT_EQ(sink.retirements.size(), 1u);
  EXPECT_EQ(sink.retirements[0].first, 7);
  EXPECT_EQ(sink.retirement_recipients[0], 3);  // on the channel of the worker that holds it
  deliver(&MergerCore::on_scene, block_scene(0, 0.f));
  core.step();
  ASSERT_EQ(sink.frames.back().created.size(), 1u);
  EXPECT_GT(sink.frames.back().created[0], 7);
}

// A merger (restarted) that listens for resumable objects (ObjectResumer).
struct ResumingMerger {
  explicit ResumingMerger(MergerCoreOptions options, MalformedCounter& malformed, ManualClock& clock)
      : core((options.resume.listen = 300ms, options.resume.report_timeout = 500ms, options), sink, malformed,
             clock.function()) {}
  template <class T>
  void deliver(void (MergerCore::*handler)(const lcm::ReceiveBuffer*, const std::string&), const T& message) {
    Bytes bytes = encode(message);
    const lcm::ReceiveBuffer buffer{bytes.data(), static_cast<std::uint32_t>(bytes.size()), 0};
    (core.*handler)(&buffer, "TEST");
  }
  RecordingSink sink;
  MergerCore core;
};

// What a worker holding `object` answers a request (TrackerWorker::on_model_request).
object_model_t report_of(const ManagedObject& object, std::int32_t worker, std::int64_t last_seq) {
  object_model_t msg = model_message(object, worker, 100 + worker, last_seq, {}, 0);
  msg.carried_by = 0;
  msg.companion = 0;
  return msg;
}

TEST_F(MergerCoreTest, ARestartedMergerResumesTheObjectsItsWorkersHoldWithTheirIdsModelsPosesAndOwners) {
  // The merger before the restart: two blocks, objects 1 and 2 on workers 0 and 1.
  deliver(&MergerCore::on_heartbeat, heartbeat_of(0, -1, -1));
  deliver(&MergerCore::on_heartbeat, heartbeat_of(1, -1, -1));
  deliver(&MergerCore::on_scene, two_block_scene(0, 0.f));
  ASSERT_EQ(core.step(), 1);
  ASSERT_EQ(core.manager().objects().size(), 2u);
  const std::int32_t owner_of_1 = core.workers().owner(1).value();
  const std::int32_t owner_of_2 = core.workers().owner(2).value();

  // It restarts; its workers go on heartbeating what they hold.
  clock.advance(1000ms);
  ResumingMerger restarted(options(), malformed, clock);
  restarted.deliver(&MergerCore::on_heartbeat, heartbeat_of(owner_of_1, 1, 0));
  restarted.deliver(&MergerCore::on_heartbeat, heartbeat_of(owner_of_2, 2, 0));
  ASSERT_EQ(restarted.sink.requests.size(), 2u);
  EXPECT_EQ(restarted.sink.requests[0].object_id, 1);
  EXPECT_EQ(restarted.sink.requests[0].worker_id, owner_of_1);
  EXPECT_EQ(restarted.sink.requests[0].worker_instance, 100 + owner_of_1);
  EXPECT_TRUE(restarted.sink.retirements.empty());  // the answer may come: nothing retired
  // Heartbeats before the answer ask nothing twice and retire nothing.
  clock.advance(250ms);
  restarted.deliver(&MergerCore::on_heartbeat, heartbeat_of(owner_of_1, 1, 0));
  EXPECT_EQ(restarted.sink.requests.size(), 2u);
  EXPECT_TRUE(restarted.sink.retirements.empty());
  restarted.deliver(&MergerCore::on_scene, two_block_scene(1, 0.f));
  EXPECT_EQ(restarted.core.step(), 0);  // frames wait for the answers
  restarted.deliver(&MergerCore::on_model_report, report_of(core.manager().objects().at(1), owner_of_1, 0));
  restarted.deliver(&MergerCore::on_model_report, report_of(core.manager().objects().at(2), owner_of_2, 0));
  EXPECT_EQ(malformed.total(), 0);
  EXPECT_EQ(restarted.core.resumer().resumed(), 2);
  clock.advance(100ms);                 // listen over, nothing pending
  EXPECT_EQ(restarted.core.step(), 0);  // frame 1 waits for its owners' estimates now
  for (const std::int32_t id : {1, 2}) {
    restarted.deliver(&MergerCore::on_estimate,
                      estimate_of(1, id, id == 1 ? owner_of_1 : owner_of_2, core.manager().objects().at(id).pose));
  }
  EXPECT_EQ(restarted.core.step(), 1);
  ASSERT_EQ(restarted.sink.frames.size(), 1u);
  EXPECT_TRUE(restarted.sink.frames[0].created.empty());
  EXPECT_TRUE(restarted.sink.frames[0].retired.empty());
  for (const std::int32_t id : {1, 2}) {
    const ManagedObject& before = core.manager().objects().at(id);
    const ManagedObject& after = restarted.core.manager().objects().at(id);
    EXPECT_EQ(after.model.cloud.size(), before.model.cloud.size());
    EXPECT_GE(after.version, before.version);
    EXPECT_TRUE(after.pose.translation.isApprox(before.pose.translation, 1e-3f));
  }
  EXPECT_TRUE(restarted.core.workers().owns(owner_of_1, 1));
  EXPECT_TRUE(restarted.core.workers().owns(owner_of_2, 2));
  // Objects 1 and 2 explain the blocks' points: no new object; a third block gets id 3.
  scene_cloud_t three = two_block_scene(2, 0.f);
  const scene_cloud_t far = block_scene(2, 0.4f);
  for (std::size_t i = 0; i < far.x.size(); ++i) {
    three.x.push_back(far.x[i]);
    three.y.push_back(far.y[i]);
    three.z.push_back(far.z[i]);
    three.r.push_back(30);
    three.g.push_back(30);
    three.b.push_back(200);
    three.u.push_back(static_cast<std::int16_t>(far.u[i] + 100));
    three.v.push_back(far.v[i]);
    three.cluster.push_back(2);
  }
  three.num_clusters = 3;
  three.num_standing_clusters = 3;
  three.num_points = static_cast<std::int32_t>(three.x.size());
  for (std::int64_t seq = 2; seq < 8; ++seq) {
    three.frame_seq = seq;
    restarted.deliver(&MergerCore::on_scene, three);
    clock.advance(600ms);  // estimates time out (poses stale), the frame goes on
    restarted.deliver(&MergerCore::on_heartbeat, heartbeat_of(owner_of_1, 1, seq));
    restarted.deliver(&MergerCore::on_heartbeat, heartbeat_of(owner_of_2, 2, seq));
    restarted.core.step();
  }
  ASSERT_EQ(restarted.core.manager().objects().size(), 3u);
  EXPECT_EQ(restarted.core.manager().objects().rbegin()->first, 3);
  EXPECT_TRUE(restarted.sink.retirements.empty());
}

TEST_F(MergerCoreTest, AForgedHeartbeatOrReportCannotMakeARestartedMergerAdoptAnObjectOrOverflowItsIds) {
  ResumingMerger restarted(options(), malformed, clock);
  // A stranger claims the largest ids: nothing is asked, the claim is counted, no id is reserved.
  restarted.deliver(&MergerCore::on_heartbeat, heartbeat_of(9, 2147483645, 0));
  restarted.deliver(&MergerCore::on_heartbeat, heartbeat_of(8, kMaxObjectId + 1, 0));
  EXPECT_TRUE(restarted.sink.requests.empty());
  EXPECT_EQ(malformed.total(), 2);
  // A stranger claims object 2: asked, but what it (or anyone else) sends is refused unless it
  // answers that request with a model.
  restarted.deliver(&MergerCore::on_heartbeat, heartbeat_of(7, 2, 0));
  ASSERT_EQ(restarted.sink.requests.size(), 1u);
  ManagedObject fake;
  fake.id = 2;
  fake.model.cloud.push_back({0.f, 0.f, 0.f}, {1, 2, 3});
  object_model_t empty = report_of(fake, 7, 0);
  empty.num_points = 0;
  empty.x.clear(), empty.y.clear(), empty.z.clear(), empty.r.clear(), empty.g.clear(), empty.b.clear();
  restarted.deliver(&MergerCore::on_model_report, empty);                  // no model
  restarted.deliver(&MergerCore::on_model_report, report_of(fake, 6, 0));  // not the worker asked
  fake.id = 3;
  restarted.deliver(&MergerCore::on_model_report, report_of(fake, 7, 0));  // not asked for
  object_model_t far = report_of(fake, 7, 0);
  far.object_id = 2;
  far.x[0] = 100.f;  // beyond kMaxModelRadius
  restarted.deliver(&MergerCore::on_model_report, far);
  EXPECT_EQ(malformed.total(), 6);
  EXPECT_TRUE(restarted.core.manager().objects().empty());
  // The request times out: frames go on, the claimed object is retired, ids stay small.
  restarted.deliver(&MergerCore::on_scene, block_scene(0, 0.f));
  EXPECT_EQ(restarted.core.step(), 0);
  clock.advance(501ms);
  EXPECT_EQ(restarted.core.step(), 1);  // object 1 is born, and goes to the idle worker 7
  clock.advance(300ms);                 // its model had time to arrive
  restarted.deliver(&MergerCore::on_heartbeat, heartbeat_of(7, 2, 0));
  // The two out of range were dropped at the boundary (counted above), never heard: only 2, after its request.
  ASSERT_EQ(restarted.sink.retirements.size(), 1u);
  EXPECT_EQ(restarted.sink.retirements.back().first, 2);
  ASSERT_EQ(restarted.sink.frames.size(), 1u);
  EXPECT_EQ(restarted.sink.frames[0].created, std::vector<std::int32_t>{1});
  // Once a frame was finished nothing is resumed, and ids never overflow.
  restarted.deliver(&MergerCore::on_heartbeat, heartbeat_of(5, 40, 0));
  EXPECT_EQ(restarted.sink.requests.size(), 1u);
  EXPECT_EQ(restarted.sink.retirements.back().first, 40);
  EXPECT_EQ(restarted.core.resumer().resumed(), 0);
}

TEST_F(MergerCoreTest, MalformedMessagesAreCountedAndTheCoreKeepsServing) {
  deliver(&MergerCore::on_heartbeat, heartbeat_of(0, -1, -1));
  Bytes truncated = encode(block_scene(0, 0.f));
  truncated.resize(truncated.size() / 2);
  const lcm::ReceiveBuffer half{truncated.data(), static_cast<std::uint32_t>(truncated.size()), 0};
  core.on_scene(&half, "MFOT_SCENE");
  EXPECT_EQ(malformed.total(), 1);
  EXPECT_EQ(core.open_frames(), 0u);
  deliver(&MergerCore::on_scene, block_scene(0, 0.f));
  core.step();
  ASSERT_EQ(sink.frames.size(), 1u);
  deliver(&MergerCore::on_scene, block_scene(1, 0.f));
  Pose pose = sink.frames[0].poses.at(1);
  auto bad = estimate_of(1, 1, 0, pose);
  bad.position[0] = std::numeric_limits<double>::quiet_NaN();
  deliver(&MergerCore::on_estimate, bad);
  bad = estimate_of(1, 1, 0, pose);
  bad.confidence = std::numeric_limits<float>::infinity();
  deliver(&MergerCore::on_estimate, bad);
  EXPECT_EQ(malformed.total(), 3);
  EXPECT_EQ(core.step(), 0);  // neither counted as the owner's answer
  deliver(&MergerCore::on_estimate, estimate_of(1, 1, 0, pose));
  EXPECT_EQ(core.step(), 1);
}

}  // namespace
}  // namespace mfot::service
