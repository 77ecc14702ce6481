#include "mfot/capture/tum_source.hpp"

#include <spdlog/spdlog.h>

#include <filesystem>

namespace mfot::capture {

TumSource::TumSource(service::TumReaderOptions options) : reader_(std::move(options)) {
  const auto truth_folder = std::filesystem::path(reader_.folder()) / "groundtruth";
  std::error_code error;
  if (std::filesystem::exists(truth_folder / "poses.csv", error)) {
    truth_.emplace(truth_folder.string());
    for (const auto& [frame, truth] : truth_->frames()) truth_frame_by_utime_[truth.utime] = frame;
    spdlog::info("{}: ground truth for {} frames", truth_folder.string(), truth_->frames().size());
  }
}

std::optional<SourceFrame> TumSource::next() {
  while (next_index_ < reader_.size()) {
    const std::size_t index = next_index_++;
    auto frame = reader_.read(index);
    if (!frame) continue;
    SourceFrame out;
    out.index = static_cast<std::int64_t>(index);
    out.frame = std::move(*frame);
    if (truth_) {
      if (const auto it = truth_frame_by_utime_.find(out.frame.capture_utime); it != truth_frame_by_utime_.end()) {
        service::GroundTruthFrame truth = truth_->frames().at(it->second);
        if (auto labels = truth_->labels(it->second)) truth.labels = std::move(*labels);
        out.truth = std::move(truth);
      }
    }
    return out;
  }
  return std::nullopt;
}

bool TumSource::rewind() {
  next_index_ = 0;
  return true;
}

void TumSource::seek(std::int64_t index) {
  if (index < 0 || static_cast<std::size_t>(index) >= reader_.size()) {
    throw CaptureError(name() + ": start frame " + std::to_string(index) + " is outside [0, " +
                       std::to_string(reader_.size()) + ")");
  }
  next_index_ = static_cast<std::size_t>(index);
}

}  // namespace mfot::capture
