// Primary-with-fallback likelihood: the GPU JCSD with the CPU JCSD for frames the GPU fails
// (see the header for the steps).

#include "mfot/cuda/fallback_likelihood.hpp"

#include <spdlog/spdlog.h>

#include <stdexcept>

namespace mfot {

FallbackLikelihood::FallbackLikelihood(std::unique_ptr<Likelihood> primary, std::unique_ptr<Likelihood> fallback)
    : primary_(std::move(primary)), fallback_(std::move(fallback)) {
  if (!primary_ || !fallback_) {
    throw std::invalid_argument("FallbackLikelihood: primary and fallback must both be non-null");
  }
}

void FallbackLikelihood::set_model(const ObjectModel& model) {
  model_ = model;
  fallback_has_model_ = false;
  primary_has_model_ = false;
  try {
    primary_->set_model(model_);
    primary_has_model_ = true;
  } catch (const std::exception& error) {
    record_failure("set_model", error);
  }
}

void FallbackLikelihood::evaluate(std::span<const Pose> particles, const HypothesisData& data,
                                  std::span<float> scores) {
  if (!primary_has_model_) {
    // The primary's last set_model failed: offer it the model again before this frame.
    try {
      primary_->set_model(model_);
      primary_has_model_ = true;
    } catch (const std::exception& error) {
      record_failure("set_model", error);
    }
  }
  if (primary_has_model_) {
    try {
      primary_->evaluate(particles, data, scores);
      return;
    } catch (const std::invalid_argument&) {
      throw;  // a caller's mistake, not a backend failure: the fallback would reject it too
    } catch (const std::exception& error) {
      record_failure("evaluate", error);
    }
  }
  if (!fallback_has_model_) {
    fallback_->set_model(model_);
    fallback_has_model_ = true;
  }
  fallback_->evaluate(particles, data, scores);
  ++fallback_frames_;
}

void FallbackLikelihood::record_failure(const char* stage, const std::exception& error) {
  last_error_ = error.what();
  if (last_error_ != last_logged_) {
    spdlog::warn("likelihood {} {} failed, scoring with {}: {}", primary_->name(), stage, fallback_->name(),
                 last_error_);
    last_logged_ = last_error_;
  }
}

}  // namespace mfot
