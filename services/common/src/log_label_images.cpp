#include "mfot/service/log_label_images.hpp"

#include <filesystem>
#include <stdexcept>

#include "mfot/segmentation_t.hpp"
#include "mfot/service/frame_codec.hpp"
#include "mfot/service/run_writer.hpp"
#include "mfot/service/service_main.hpp"

namespace mfot::service {

namespace {
// Matched frames drawn together, per thread: enough to keep every thread busy, few enough that the
// encoded frames held meanwhile stay a few megabytes.
constexpr std::size_t kJobsPerThread = 4;
}  // namespace

LogLabelImages::LogLabelImages(std::string run_dir, int threads, MalformedCounter& malformed)
    : run_dir_(std::move(run_dir)), malformed_(malformed), pool_(threads) {
  std::error_code ec;
  std::filesystem::create_directories(run_dir_ + "/labels", ec);
  if (ec) throw OutputError(run_dir_ + "/labels: cannot create: " + ec.message());
}

void LogLabelImages::add(const LcmLogEvent& event) {
  const bool frame = event.channel == channel::kFrame, scene = event.channel == channel::kScene,
             segmentation = event.channel == channel::kSegmentation;
  if (!frame && !scene && !segmentation) return;
  const lcm::ReceiveBuffer rbuf{const_cast<std::uint8_t*>(event.data.data()),
                                static_cast<std::uint32_t>(event.data.size()), event.utime};
  std::int64_t seq = 0;
  if (frame) {
    frame_t msg;
    if (!decode_message(&rbuf, event.channel, msg, malformed_)) return;
    if (auto why = implausible_frame_sizes(msg)) {
      malformed_.record(event.channel, "implausible frame", *why);
      return;
    }
    seq = msg.seq;
    if (drawn_.count(seq) > 0) return;
    frames_[seq] = std::move(msg);
    bound(frames_, false);
  } else if (scene) {
    std::optional<Scene> decoded = receive_scene(&rbuf, event.channel, malformed_);
    if (!decoded) return;
    seq = decoded->frame_seq;
    if (drawn_.count(seq) > 0) return;  // the merger's re-sent scene
    scenes_.try_emplace(seq, std::move(*decoded));
    bound(scenes_, false);
  } else {
    segmentation_t msg;
    if (!decode_message(&rbuf, event.channel, msg, malformed_)) return;
    seq = msg.frame_seq;
    if (drawn_.count(seq) > 0 || segmentations_.count(seq) > 0) {
      ++counts_.repeated;
      return;
    }
    segmentations_.emplace(seq, std::move(msg.label));
    bound(segmentations_, true);
  }
  try_match(seq);
}

template <class Map>
void LogLabelImages::bound(Map& pending, bool is_segmentation) {
  while (pending.size() > kMaxPendingFrames) {
    const std::int64_t oldest = pending.begin()->first;
    pending.erase(pending.begin());
    if (is_segmentation) count_unmatched_segmentation(oldest);
  }
}

void LogLabelImages::count_unmatched_segmentation(std::int64_t seq) {
  if (frames_.count(seq) == 0) ++counts_.without_frame;
  if (scenes_.count(seq) == 0) ++counts_.without_scene;
}

void LogLabelImages::try_match(std::int64_t seq) {
  const auto frame = frames_.find(seq);
  const auto scene = scenes_.find(seq);
  const auto segmentation = segmentations_.find(seq);
  if (frame == frames_.end() || scene == scenes_.end() || segmentation == segmentations_.end()) return;
  if (segmentation->second.size() != scene->second.cloud.size()) {
    ++counts_.mismatched;
  } else {
    queued_.push_back({seq, std::move(frame->second), std::move(scene->second), std::move(segmentation->second)});
  }
  frames_.erase(frame);
  scenes_.erase(scene);
  segmentations_.erase(segmentation);
  drawn_.insert(seq);
  if (queued_.size() >= kJobsPerThread * static_cast<std::size_t>(pool_.threads())) draw_queued();
}

void LogLabelImages::draw_queued() {
  std::vector<char> undecodable(queued_.size(), 0);  // set by the drawing threads
  pool_.run(queued_.size(), [&](std::size_t k) {
    const Job& job = queued_[k];
    Image16 image;
    try {
      image = frame_label_image(job.frame, job.scene.voxel_grid, job.scene.cloud.positions, job.labels);
    } catch (const FrameCodecError& e) {
      undecodable[k] = 1;
      malformed_.record(channel::kFrame, "undecodable frame", e.what());  // MalformedCounter locks
      return;
    }
    write_label_image(run_dir_, job.seq, image);
  });
  for (const char bad : undecodable) {
    if (bad) {
      ++counts_.undecodable;
    } else {
      ++counts_.written;
    }
  }
  queued_.clear();
}

LabelImageCounts LogLabelImages::finish() {
  draw_queued();
  for (const auto& [seq, labels] : segmentations_) count_unmatched_segmentation(seq);
  segmentations_.clear();
  frames_.clear();
  scenes_.clear();
  return counts_;
}

}  // namespace mfot::service
