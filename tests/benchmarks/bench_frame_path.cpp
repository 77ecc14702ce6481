// Per-frame work of the services outside the tracker likelihood, timed on the messages of a
// recorded run (scripts/mfot-run writes RUN/mfot.lcmlog): frame decoding (whole frame and depth
// only), the dense label image and its PNG file, the fitting distance, and the LCM scene message
// round trip. Wall clock (steady clock), one thread; on a busy machine compare relative figures.
//
// Usage: mfot_bench_frame_path RUN/mfot.lcmlog [max_frames=200] [scratch_dir=/tmp]
// It also checks that the label images it computes equal the run's RUN/labels/<frame>.png, so a
// faster label writer is checked against an earlier build's output.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "bench_timing.hpp"
#include "mfot/frame_done_t.hpp"
#include "mfot/frame_t.hpp"
#include "mfot/metrics.hpp"
#include "mfot/object_model_t.hpp"
#include "mfot/scene_cloud_t.hpp"
#include "mfot/segmentation_t.hpp"
#include "mfot/service/convert.hpp"
#include "mfot/service/frame_codec.hpp"
#include "mfot/service/image_io.hpp"
#include "mfot/service/lcm_log_reader.hpp"
#include "mfot/service/run_writer.hpp"

namespace {

using mfot::bench::Clock;
using mfot::bench::ms_since;
using mfot::bench::Series;

struct Recorded {
  std::map<std::int64_t, mfot::frame_t> frames;
  std::map<std::int64_t, mfot::scene_cloud_t> scenes;
  std::map<std::int64_t, mfot::segmentation_t> segmentations;
  // Per frame: each object's model as of that frame, at its pose of the frame (object id -> model message).
  std::map<std::int64_t, std::map<std::int32_t, mfot::object_model_t>> models;
};

template <class Message>
bool decode_event(const mfot::service::LcmLogEvent& event, Message& out) {
  const auto size = static_cast<int>(event.data.size());
  return out.decode(event.data.data(), 0, size) == size;
}

Recorded read_log(const std::string& path, std::size_t max_frames) {
  mfot::service::LcmLogReader log(path);  // throws naming the path and byte offset of a broken log
  Recorded r;
  std::map<std::int32_t, mfot::object_model_t> latest;  // each object's last model sent
  while (const auto event = log.next()) {
    if (event->channel == "MFOT_FRAME" && r.frames.size() < max_frames) {
      mfot::frame_t m;
      if (decode_event(*event, m)) r.frames[m.seq] = std::move(m);
    } else if (event->channel == "MFOT_SCENE") {
      mfot::scene_cloud_t m;
      if (decode_event(*event, m) && r.frames.count(m.frame_seq)) r.scenes[m.frame_seq] = std::move(m);
    } else if (event->channel.rfind("MFOT_MODEL_", 0) == 0) {  // sent when a model changes
      mfot::object_model_t m;
      if (decode_event(*event, m) && m.num_points > 0) latest[m.object_id] = std::move(m);
    } else if (event->channel == "MFOT_FRAME_DONE") {  // every object's pose of the frame
      mfot::frame_done_t m;
      if (!decode_event(*event, m) || !r.frames.count(m.frame_seq)) continue;
      for (const mfot::frame_done_object_t& entry : m.objects) {
        const auto model = latest.find(entry.object_id);
        if (model == latest.end()) continue;
        mfot::object_model_t& at_frame = r.models[m.frame_seq][entry.object_id] = model->second;
        std::copy(entry.position, entry.position + 3, at_frame.position);
        std::copy(entry.orientation, entry.orientation + 4, at_frame.orientation);
      }
    } else if (event->channel == "MFOT_SEGMENTATION") {
      mfot::segmentation_t m;
      if (decode_event(*event, m) && r.frames.count(m.frame_seq)) r.segmentations[m.frame_seq] = std::move(m);
    }
  }
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s RUN/mfot.lcmlog [max_frames=200] [scratch_dir=/tmp]\n", argv[0]);
    return 2;
  }
  const std::size_t max_frames = argc > 2 ? static_cast<std::size_t>(std::atoi(argv[2])) : 200;
  const std::string scratch = argc > 3 ? argv[3] : "/tmp";
  const Recorded rec = read_log(argv[1], max_frames);
  const std::string log_path = argv[1];
  const std::string run_dir =
      log_path.substr(0, log_path.find_last_of('/') == std::string::npos ? 0 : log_path.find_last_of('/'));
  int labels_compared = 0, labels_differing = 0;
  std::printf("%zu frames, %zu scenes, %zu segmentations from %s\n", rec.frames.size(), rec.scenes.size(),
              rec.segmentations.size(), argv[1]);

  std::map<std::string, Series> series;
  mfot::FittingDistanceEvaluator fitting;
  mfot::FittingDistanceEvaluator plain_fitting(mfot::FittingDistanceOptions{.occlusion_test = false});
  std::vector<std::uint8_t> buffer;
  for (const auto& [seq, message] : rec.frames) {
    auto t = Clock::now();
    const mfot::service::Frame frame = mfot::service::decode_frame(message);
    series["decode frame (depth + colour)"].values.push_back(ms_since(t));

    const auto scene_it = rec.scenes.find(seq);
    const auto seg_it = rec.segmentations.find(seq);
    if (scene_it == rec.scenes.end() || seg_it == rec.segmentations.end()) continue;
    const mfot::scene_cloud_t& scene_message = scene_it->second;

    t = Clock::now();
    buffer.resize(static_cast<std::size_t>(scene_message.getEncodedSize()));
    scene_message.encode(buffer.data(), 0, static_cast<int>(buffer.size()));
    series["scene message encode"].values.push_back(ms_since(t));
    t = Clock::now();
    mfot::scene_cloud_t decoded;
    decoded.decode(buffer.data(), 0, static_cast<int>(buffer.size()));
    series["scene message decode"].values.push_back(ms_since(t));
    t = Clock::now();
    mfot::service::Scene scene;
    if (auto error = mfot::service::scene_from_message(decoded, scene)) {
      std::fprintf(stderr, "scene %lld: %s\n", static_cast<long long>(seq), error->c_str());
      return 1;
    }
    series["scene from message"].values.push_back(ms_since(t));

    t = Clock::now();
    const mfot::service::Image16 labels =
        mfot::service::dense_labels(frame.width, frame.height, frame.fx, frame.fy, frame.cx, frame.cy, frame.depth_mm,
                                    scene.voxel_grid, scene.cloud.positions, seg_it->second.label);
    series["dense labels"].values.push_back(ms_since(t));
    char name[32];
    std::snprintf(name, sizeof name, "/labels/%06lld.png", static_cast<long long>(seq));
    const std::string recorded = run_dir + name;
    if (std::FILE* file = std::fopen(recorded.c_str(), "rb")) {
      std::fclose(file);
      ++labels_compared;
      if (mfot::service::read_png16(recorded).pixels != labels.pixels) ++labels_differing;
    }
    for (const auto& [compression, name] : {std::pair{mfot::service::PngCompression::kFast, "fast"},
                                            std::pair{mfot::service::PngCompression::kSmall, "small"}}) {
      const std::string path = scratch + "/mfot_bench_labels_" + name + ".png";
      t = Clock::now();
      mfot::service::write_png16(path, labels, compression);
      series[std::string("label PNG file, ") + name].values.push_back(ms_since(t));
      series[std::string("label PNG kB, ") + name].values.push_back(
          static_cast<double>(std::filesystem::file_size(path)) / 1e3);
      std::filesystem::remove(path);
    }

    t = Clock::now();
    const mfot::service::Frame depth_only = mfot::service::decode_frame(message, mfot::service::FrameParts::kDepthOnly);
    series["decode frame (depth only)"].values.push_back(ms_since(t));
    if (depth_only.depth_mm != frame.depth_mm) {
      std::fprintf(stderr, "frame %lld: depth-only decoding differs\n", static_cast<long long>(seq));
      return 1;
    }

    t = Clock::now();
    fitting.set_scene(scene.cloud.positions);
    series["fitting distance: scene index"].values.push_back(ms_since(t));
    if (const auto models = rec.models.find(seq); models != rec.models.end()) {
      // Decoded once, outside the timing: the merger holds its models decoded.
      std::vector<std::pair<mfot::ObjectModel, mfot::Pose>> objects;
      for (const auto& [id, model_message] : models->second) {
        mfot::ObjectModel model;
        mfot::Pose pose;
        mfot::PoseVector velocity;
        if (!mfot::service::model_from_message(model_message, model, pose, velocity)) objects.emplace_back(model, pose);
      }
      t = Clock::now();
      for (const auto& [model, pose] : objects) fitting.evaluate(model.cloud.positions, pose);
      series["fitting distance: all objects"].values.push_back(ms_since(t));
      t = Clock::now();
      plain_fitting.set_scene(scene.cloud.positions);
      for (const auto& [model, pose] : objects) plain_fitting.evaluate(model.cloud.positions, pose);
      series["fitting distance: no occlusion test"].values.push_back(ms_since(t));
    }
  }
  std::printf("label images equal to the run's: %d of %d\n", labels_compared - labels_differing, labels_compared);
  std::printf("median ms per frame:\n");
  for (const auto& [name, s] : series)
    std::printf("  %-32s %8.3f  (%zu frames)\n", name.c_str(), s.median(), s.values.size());
  return labels_differing == 0 ? 0 : 1;
}
