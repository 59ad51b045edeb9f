#pragma once
// Adam for a Gaussian field, one parameter group per tensor, fused and in place: one parallel pass over
// each parameter's contiguous buffer updates moments and values together (torch::optim::Adam makes
// ~10 temporaries per tensor). Moments live in tensors shaped like their parameter, so that
// densification can gather, append and drop rows in step with the parameters.
//
// Two exact savings over a plain dense Adam: SH bands above the active degree are skipped (their
// gradients and moments are exactly zero until the band is switched on, so Adam would not move them);
// and, optionally (`sparse`), rows that received no gradient this step are skipped, as in the
// "sparse Adam" of later Inria code (which skips the Gaussians outside the view; the trainer passes the
// ones no pixel reached, a smaller set). The latter changes the maths (their moments neither decay nor
// carry momentum), so it is off by default.
#include <array>
#include <cstdint>

#include <torch/types.h>

#include "lrf/splat/gaussians.h"
#include "lrf/splat/raster/sh.h"

namespace lrf::splat {

// Inria's short run (its 7k-step checkpoint): runs shorter than this compress their densification schedule
// (DensifySchedule::for_iterations) and, for latent fields, speed up their rates (for_short_run) by the same ratio.
constexpr int64_t kInriaShortRunSteps = 7000;

struct LearningRates {
  double position_init = 1.6e-4;  // times the scene extent
  double position_final = 1.6e-6;
  double scales = 5e-3;
  double rotations = 1e-3;
  double opacity = 5e-2;
  double sh_dc = 2.5e-3;
  double sh_rest = 2.5e-3 / 20.0;
  // The rates of scales, rotations, opacity and SH are multiplied by a factor going log-linearly from 1 at
  // the first step to this at the last (1: constant, as in Inria's 3DGS; refinement decays them).
  double others_final_factor = 1.0;
  // The fraction of the run before which every rate stays at its start and after which the decays above
  // run to their ends by the last step (0: from the first step). Refinement: constant rates make the
  // progress, and a short decay at the end keeps the last views seen from deciding the result.
  double decay_start = 0.0;
  // Where `step` (0-based) of `total` steps is in the decays: 0 before decay_start, 1 at the end.
  double decay_progress(int64_t step, int64_t total) const;
  // others_final_factor's decay at `step` of `total`: 1 until the decay starts, others_final_factor at the end.
  double others_factor(int64_t step, int64_t total) const;

  // These rates with the means' and the SH coefficients' scaled by short_run_factor(iterations): a run
  // shorter than Inria's short run compresses its schedule by iterations / 7000
  // (DensifySchedule::for_iterations), and moves its Gaussians' means and features as much in fewer steps.
  LearningRates for_short_run(int64_t iterations) const;
  // 7000 / iterations, from 1 (7000 steps or more) up to kMaxShortRunFactor.
  static double short_run_factor(int64_t iterations);
  static constexpr double kMaxShortRunFactor = 4.0;
};

// The scalars of one Adam update at step t (bias corrections folded in), in float as the update runs.
struct AdamScalars {
  float beta1, beta2, one_minus_beta1, one_minus_beta2, step_size, inv_sqrt_bc2, eps;
};
AdamScalars adam_scalars(double lr, double beta1, double beta2, double eps, int64_t t);

// PyTorch's Adam update of n contiguous floats: m ← β1·m + (1 − β1)·g, v ← β2·v + (1 − β2)·g·g,
// p ← p − step·m / (√v / √bc2 + ε). Eight lanes at a time where the CPU has AVX2; every lane does the
// scalar loop's operations in its order (IEEE square root and division, no fused multiply-add), so the
// result does not depend on the CPU. `vectorised` = false forces the scalar loop (for the test).
void adam_update(float* p, const float* g, float* m, float* v, int64_t n, const AdamScalars& s,
                 bool vectorised = true);

class GaussianAdam {
 public:
  static constexpr int kGroups = 5;  // order of Gaussians::parameters()

  GaussianAdam() = default;
  GaussianAdam(const Gaussians& g, const LearningRates& lr, double extent, int64_t total_steps);

  // The position learning rate at `step` (0-based): log-linear from init to final over total_steps.
  double position_lr(int64_t step) const;
  // The factor of the other groups' rates at `step` (see LearningRates::others_final_factor).
  double others_factor(int64_t step) const;
  // One update of every parameter that has a gradient. active_sh_degree limits the SH bands moved;
  // `rows` ([N] bool or undefined) restricts the update to those rows when `sparse` is set.
  void step(Gaussians& g, int active_sh_degree, const torch::Tensor& rows = {});
  int64_t steps_taken() const { return steps_; }

  // The SH group's part of the coming step(), for the render backward to apply row by row while each
  // gradient row is in cache (RasterSettings::sh_gradient_sink), instead of step() reading back an
  // [N, K, C] gradient tensor: the same arithmetic, bit for bit. Valid until that step(), which then skips
  // the SH group and fails if an SH gradient reached the tensor by another path. Not with `sparse`.
  const ShGradientSink& sh_row_update(Gaussians& g, int active_sh_degree);

  // Row edits mirroring densification: row i of the new state is row source[i] of the old one; rows
  // from first_new on (clones, split children) start at zero.
  void gather_rows(const torch::Tensor& source, int64_t first_new);
  // Zero the moments of one group (after an opacity reset, as the Inria code does).
  void reset_group(int group);

  bool sparse = false;
  double beta1 = 0.9, beta2 = 0.999, eps = 1e-15;

  // State for checkpoints: [m0..m4, v0..v4].
  std::vector<torch::Tensor> state() const;
  void set_state(const std::vector<torch::Tensor>& tensors, int64_t steps);

 private:
  // A group's rows: their length, the spans updated at the first and second rate and those rates' scalars;
  // for the SH group of a row-by-row update also where the rows live (see sh_row_update).
  struct GroupRows {
    float *p = nullptr, *m = nullptr, *v = nullptr;
    int64_t row = 0, seg0 = 0, seg1 = 0;
    AdamScalars s0{}, s1{};
  };
  // The spans of a row updated at each rate and their scalars, for group k at step t (1-based).
  GroupRows group_rows(const Gaussians& g, int k, int64_t t, int active_sh_degree) const;
  // One row's update (parameters p, gradient g, moments m and v at the row's start), shared by step() and
  // the row-by-row SH update so that the two stay the same arithmetic.
  static void update_row(const GroupRows& r, float* p, const float* g, float* m, float* v);

  LearningRates lr_;
  double extent_ = 1;
  int64_t total_ = 1;
  int64_t steps_ = 0;
  std::array<torch::Tensor, kGroups> m_, v_;
  GroupRows sh_rows_;
  ShGradientSink sh_sink_;
  bool sh_rows_pending_ = false;
};

}  // namespace lrf::splat
