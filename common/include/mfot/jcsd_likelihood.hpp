#pragma once
// JCSD hypothesis evaluation on the CPU, thesis 3.3, equations 3.18 to 3.20.

#include "mfot/jcsd_grid.hpp"
#include "mfot/likelihood.hpp"

#include <cstdint>
#include <memory>

namespace mfot {

struct JcsdLikelihoodOptions {
  JcsdGridOptions grid;  // grid built from the model by set_model
  int threads = 1;       // threads across particles, [1, 256]; 1 runs on the caller's thread
};

// Scores particles against the model's JCSD grid (thesis 3.3). Steps:
//  1. set_model: build J with Algorithm 3 (build_jcsd_grid).
//  2. evaluate, once per call: copy the hypothesis data into structure-of-arrays buffers (positions
//     and the three non-zero SMR bins of each point as offsets into a corner's 8 values).
//  3. per particle: map the points into grid units with the inverse pose (3.18's object frame),
//     interpolate J trilinearly at the 8 corners of each point's cell, correlate with the sparse
//     SMR (3.19) and sum over points (3.20). Points whose cell is not inside the grid score 0.
// Particles are split into contiguous blocks across `threads` (a pool owned by this object); each
// score is computed by one thread with the same arithmetic, so results do not depend on the
// thread count. No allocation per particle; buffers grow only when the hypothesis data grows.
class JcsdLikelihood final : public Likelihood {
 public:
  explicit JcsdLikelihood(const JcsdLikelihoodOptions& options = {});
  ~JcsdLikelihood() override;
  JcsdLikelihood(const JcsdLikelihood&) = delete;
  JcsdLikelihood& operator=(const JcsdLikelihood&) = delete;

  std::string_view name() const override { return "jcsd-cpu"; }
  void set_model(const ObjectModel& model) override;
  // Uses a grid built elsewhere (e.g. shared with another backend).
  void set_grid(JcsdGrid grid);
  const JcsdGrid& grid() const { return grid_; }

  void evaluate(std::span<const Pose> particles, const HypothesisData& data,
                std::span<float> scores) override;

 private:
  class WorkerPool;

  void score_block(std::span<const Pose> particles, std::span<float> scores) const;
  float score_particle(const Pose& particle) const;

  JcsdLikelihoodOptions options_;
  JcsdGrid grid_;
  // Hypothesis data of the current evaluate call, padded to a multiple of 8 points with
  // zero-weight entries so the inner loop has no remainder.
  std::size_t padded_points_ = 0;
  std::vector<float> x_, y_, z_;
  std::vector<std::int32_t> offset_lo_, offset_hi_, offset_gray_;
  std::vector<float> weight_lo_, weight_hi_, weight_gray_;
  std::unique_ptr<WorkerPool> pool_;
};

}  // namespace mfot
