#include "mfot/capture/lcmlog_source.hpp"

#include <spdlog/spdlog.h>

#include "mfot/service/lcm_util.hpp"

namespace mfot::capture {

LcmLogSource::LcmLogSource(std::string path) : path_(std::move(path)) { open(); }

void LcmLogSource::open() {
  try {
    log_ = std::make_unique<service::LcmLogReader>(path_);
  } catch (const service::LcmLogError& e) {
    throw CaptureError(e.what());
  }
  index_ = 0;
}

std::optional<SourceFrame> LcmLogSource::next() {
  service::MalformedCounter malformed;  // logs the first of each kind; the count is ours
  // A recording's frames carry the recording group's envelopes: not checked (capture stamps them anew).
  for (;;) {
    std::optional<service::LcmLogEvent> event;
    try {
      event = log_->next();
    } catch (const service::LcmLogError& e) {
      throw CaptureError(fmt::format("{} ({} frames read before it)", e.what(), index_));
    }
    if (!event) {
      if (undecodable_ > 0) {
        spdlog::warn("{}: {} MFOT_FRAME events did not decode and were skipped; {} frames read", path_, undecodable_,
                     index_);
      }
      return std::nullopt;
    }
    if (event->channel != service::channel::kFrame) continue;
    const lcm::ReceiveBuffer buffer{event->data.data(), static_cast<std::uint32_t>(event->data.size()), event->utime};
    SourceFrame item;
    frame_t message;
    if (!service::decode_message(&buffer, event->channel, message, malformed, /*authenticate=*/false)) {
      ++undecodable_;
      spdlog::warn("{}: event {} at byte {} on {} does not decode as frame_t; skipped ({} so far)", path_,
                   event->event_number, event->offset, event->channel, undecodable_);
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
