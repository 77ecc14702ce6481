#pragma once
// The run folder's label images (labels/<frame %06d>.png, dense_labels in run_writer.hpp), made from
// a run's lcm log after the run rather than by the merger while it runs: the images are for
// evaluation only, and on a 2-core machine drawing them per frame (decoding each frame's depth, the
// dense image, its PNG) took about a quarter of the merger's CPU from the frame-to-pose path.
//
// Steps, for every event of the log in log order:
//  1. Keep MFOT_FRAME, MFOT_SCENE and MFOT_SEGMENTATION messages that pass decode_message with the
//     process's MessageAuthenticator (the run's group and key, installed from its config): another
//     group's traffic on the URL, forged or replayed messages are counted, never drawn.
//  2. Match the three by frame sequence number. The first segmentation of a frame wins (a restarted
//     merger may finish a frame again); at most kMaxPendingFrames unmatched frames, scenes and
//     segmentations each are kept, the oldest dropped first, so a log of any length holds no more
//     than that many messages in memory (and the numbers of the frames drawn, 8 bytes each).
//  3. Draw the matched frames side by side on `threads` threads: the frame's depth only is decoded,
//     the labels of the scene points spread over the pixels of their voxels (dense_labels), and the
//     PNG written under a temporary name and renamed (RunWriter::write_labels), so an image appears
//     whole or not at all. The images are byte for byte those the merger drew per frame.

#include <cstdint>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "mfot/frame_t.hpp"
#include "mfot/service/convert.hpp"
#include "mfot/service/lcm_log_reader.hpp"
#include "mfot/service/status.hpp"
#include "mfot/thread_pool.hpp"

namespace mfot::service {

struct LabelImageCounts {
  std::int64_t written = 0;        // label images written
  std::int64_t without_frame = 0;  // segmentations whose MFOT_FRAME never came (or was dropped as too old)
  std::int64_t without_scene = 0;  // segmentations whose MFOT_SCENE never came (or was dropped as too old)
  std::int64_t repeated = 0;       // further segmentations of a frame already drawn (the first is kept)
  std::int64_t mismatched = 0;     // segmentations whose label count is not their scene's point count
  std::int64_t undecodable = 0;    // matched frames whose depth could not be decoded
};

class LogLabelImages {
 public:
  // Unmatched messages of each kind kept while waiting for the rest of their frame.
  static constexpr std::size_t kMaxPendingFrames = 64;

  // Writes into `run_dir`/labels (created; OutputError naming it when it cannot be). threads in
  // [1, 64]. Rejected messages are counted in `malformed`.
  LogLabelImages(std::string run_dir, int threads, MalformedCounter& malformed);
  LogLabelImages(const LogLabelImages&) = delete;
  LogLabelImages& operator=(const LogLabelImages&) = delete;

  // One event of the log, in log order; other channels are ignored. Throws OutputError (path and the
  // system's reason) when an image cannot be written.
  void add(const LcmLogEvent& event);
  // Draws what is still queued and counts the segmentations left without their frame or scene.
  LabelImageCounts finish();

 private:
  struct Job {
    std::int64_t seq = 0;
    frame_t frame;
    Scene scene;
    std::vector<std::int32_t> labels;
  };
  void try_match(std::int64_t seq);
  void draw_queued();
  template <class Map>
  void bound(Map& pending, bool is_segmentation);
  void count_unmatched_segmentation(std::int64_t seq);

  std::string run_dir_;
  MalformedCounter& malformed_;
  ThreadPool pool_;
  std::map<std::int64_t, frame_t> frames_;
  std::map<std::int64_t, Scene> scenes_;
  std::map<std::int64_t, std::vector<std::int32_t>> segmentations_;
  std::set<std::int64_t> drawn_;
  std::vector<Job> queued_;
  LabelImageCounts counts_;
};

}  // namespace mfot::service
