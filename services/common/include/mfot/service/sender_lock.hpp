#pragma once
// Which process a receiver takes one kind of message from (issue 55): the first sender heard is
// adopted (envelope_t.sender, authenticated when the group has a key); another sender's messages are
// refused while the adopted one is alive, i.e. heard within `timeout`; once it has been silent that
// long (a restarted merger is a new process), the next sender heard is adopted. Transport-free, the
// clock passed in. Used by trackers for MFOT_MODEL: a model is taken only from the group's merger.

#include <chrono>
#include <cstdint>
#include <optional>

namespace mfot::service {

class SenderLock {
 public:
  using Clock = std::chrono::steady_clock;

  explicit SenderLock(Clock::duration timeout) : timeout_(timeout) {}

  // A message from `sender` at `now`: true to take it (adopting the sender when none is alive).
  bool accepts(std::int64_t sender, Clock::time_point now) {
    if (!owner_ || *owner_ == sender || now - heard_ > timeout_) {
      owner_ = sender;
      heard_ = now;
      return true;
    }
    return false;
  }
  // A sign of life of `sender` that is not itself taken (e.g. its status): refreshes the owner, or
  // adopts the sender when none is alive.
  void heard(std::int64_t sender, Clock::time_point now) { accepts(sender, now); }

  std::optional<std::int64_t> owner() const { return owner_; }

 private:
  Clock::duration timeout_;
  std::optional<std::int64_t> owner_;
  Clock::time_point heard_{};
};

}  // namespace mfot::service
