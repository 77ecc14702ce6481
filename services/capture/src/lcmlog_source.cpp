#include "mfot/capture/lcmlog_source.hpp"

#include "mfot/service/lcm_util.hpp"

#include <spdlog/spdlog.h>

namespace mfot::capture {

LcmLogSource::LcmLogSource(std::string path) : path_(std::move(path)) { open(); }

void LcmLogSource::open() {
  log_ = std::make_unique<lcm::LogFile>(path_, "r");
  if (!log_->good()) throw CaptureError(path_ + ": cannot open the lcm log");
  index_ = 0;
}

std::optional<SourceFrame> LcmLogSource::next() {
  service::MalformedCounter malformed;  // logs the first of each kind; the count is ours
  // A recording's frames carry the recording group's envelopes: not checked (capture stamps them anew).
  for (;;) {
    const lcm::LogEvent* event = log_->readNextEvent();
    if (event == nullptr) return std::nullopt;
    if (event->channel != service::channel::kFrame) continue;
    const lcm::ReceiveBuffer buffer{event->data, static_cast<std::uint32_t>(event->datalen), event->timestamp};
    SourceFrame item;
    frame_t message;
    if (event->datalen < 0 || !service::decode_message(&buffer, event->channel, message, malformed,
                                                                /*authenticate=*/false)) {
      ++undecodable_;
      spdlog::warn("{}: event {} on {} does not decode as frame_t; skipped ({} so far)", path_, event->eventnum,
                   event->channel, undecodable_);
      continue;
    }
    item.index = index_++;
    item.frame.capture_utime = message.capture_utime;
    item.frame.width = message.width;
    item.frame.height = message.height;
    item.encoded = std::move(message);
    return item;
  }
}

bool LcmLogSource::rewind() {
  open();
  return true;
}

}  // namespace mfot::capture
