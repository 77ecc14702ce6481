#pragma once
// TUM RGB-D folder source: the associated rgb/depth pairs in time order; unreadable pairs are
// skipped with a warning. When the folder has groundtruth/ (written by mfot-simulate), each
// frame carries the ground truth whose utime equals its capture time.

#include <map>

#include "mfot/capture/frame_source.hpp"

namespace mfot::capture {

class TumSource final : public FrameSource {
 public:
  explicit TumSource(service::TumReaderOptions options);

  std::optional<SourceFrame> next() override;
  std::string name() const override { return "tum:" + reader_.folder(); }
  std::string kind() const override { return "tum"; }
  bool rewind() override;
  void seek(std::int64_t index) override;

  std::size_t size() const { return reader_.size(); }
  const service::TumDatasetReader& reader() const { return reader_; }

 private:
  service::TumDatasetReader reader_;
  std::optional<service::GroundTruthReader> truth_;
  std::map<std::int64_t, std::int64_t> truth_frame_by_utime_;
  std::size_t next_index_ = 0;
};

}  // namespace mfot::capture
