#pragma once
// A likelihood that survives a failing primary backend (the GPU): the frame a primary call
// throws is evaluated by the fallback (the CPU JCSD), so the tracker never loses a frame.

#include <cstddef>
#include <memory>
#include <string>

#include "mfot/likelihood.hpp"

namespace mfot {

// Steps:
//  1. set_model: keep a copy of the model for the fallback, then hand it to the primary; a
//     primary failure here is recorded and routes the next evaluations to the fallback.
//  2. evaluate: call the primary; on std::exception (std::runtime_error with the CUDA error text
//     from CudaJcsdLikelihood) record the message, log it once per distinct message (spdlog
//     warning), give the fallback the model if it has not got it yet, and evaluate the same
//     frame on the fallback. Later frames try the primary again (a transient failure such as an
//     out-of-memory costs one frame); a primary that keeps failing costs one failed call a frame.
// The fallback builds its model lazily, so the CPU grid is only built when it is needed.
class FallbackLikelihood final : public Likelihood {
 public:
  // Both must be non-null (std::invalid_argument otherwise).
  FallbackLikelihood(std::unique_ptr<Likelihood> primary, std::unique_ptr<Likelihood> fallback);
  FallbackLikelihood(const FallbackLikelihood&) = delete;
  FallbackLikelihood& operator=(const FallbackLikelihood&) = delete;

  // The primary's name: this object stands for the primary backend.
  std::string_view name() const override { return primary_->name(); }
  void set_model(const ObjectModel& model) override;
  void evaluate(std::span<const Pose> particles, const HypothesisData& data, std::span<float> scores) override;

  // Message of the last primary failure; empty while the primary has never failed.
  const std::string& last_error() const { return last_error_; }
  // Frames (evaluate calls) that the fallback scored.
  std::size_t fallback_frames() const { return fallback_frames_; }

 private:
  void record_failure(const char* stage, const std::exception& error);

  std::unique_ptr<Likelihood> primary_;
  std::unique_ptr<Likelihood> fallback_;
  ObjectModel model_;  // the current model, for the fallback
  bool primary_has_model_ = false;
  bool fallback_has_model_ = false;
  std::string last_error_;
  std::string last_logged_;
  std::size_t fallback_frames_ = 0;
};

}  // namespace mfot
