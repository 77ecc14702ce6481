#pragma once
// JCSD hypothesis evaluation on the CPU, thesis 3.3, equations 3.18 to 3.20.

#include <cstdint>
#include <memory>
#include <vector>

#include "mfot/jcsd_grid.hpp"
#include "mfot/likelihood.hpp"

namespace mfot {

struct JcsdLikelihoodOptions {
  JcsdGridOptions grid;  // grid built from the model by set_model
  int threads = 1;       // threads across particles, [1, 256]; 1 runs on the caller's thread
};

// Scores particles against the model's JCSD grid (thesis 3.3). Steps:
//  1. set_model / set_grid: build J with Algorithm 3 (build_jcsd_grid) and keep an aligned copy
//     of it followed by a block of zero corners that points outside the grid read instead.
//  2. evaluate, once per call: copy the hypothesis data into structure-of-arrays buffers
//     (positions, and each point's SMR vector h as 8 dense floats).
//  3. per particle, in batches of points: map the points into grid units with the inverse pose
//     (3.18's object frame) and keep each point's cell and fractional position. Then, per point,
//     interpolate all 8 colour densities of J trilinearly (3.18) from its cell's 8 corners, each
//     corner one contiguous 32-byte load, and accumulate h times them per bin; after the last
//     point the bins are added up. Since h . (sum_s w_s J(:, s)) = sum_s w_s (h . J(:, s)), this is
//     3.19 summed over points (3.20), without gathers. Points whose cell is not inside the grid
//     score 0. (The CUDA evaluator correlates at each corner first: the same sum, rounded
//     differently.)
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

  void evaluate(std::span<const Pose> particles, const HypothesisData& data, std::span<float> scores) override;

 private:
  class WorkerPool;

  // Fills corners_ from grid_.
  void copy_corners();
  void score_block(std::span<const Pose> particles, std::span<float> scores) const;
  float score_particle(const Pose& particle) const;

  // One grid corner's 8 colour densities, or one point's dense SMR vector: a 32-byte load.
  struct alignas(32) Bins {
    float values[kSmrBins];
  };

  JcsdLikelihoodOptions options_;
  JcsdGrid grid_;
  // grid_.values as Bins, then zero corners covering an outside point's 8 corner reads.
  std::vector<Bins> corners_;
  std::int32_t outside_corner_ = 0;  // index of the first zero corner
  // Hypothesis data of the current evaluate call, padded to a multiple of 8 points with
  // zero-h entries so the batches have no remainder.
  std::size_t padded_points_ = 0;
  std::vector<float> x_, y_, z_;
  std::vector<Bins> smr_;
  std::unique_ptr<WorkerPool> pool_;
};

}  // namespace mfot
