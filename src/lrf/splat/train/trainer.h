#pragma once
// The 3DGS training loop for any channel count: a list of training views (camera + target tensor
// [C, H, W]), a field to start from, and Inria's recipe (loss, Adam schedule, densification, SH degree
// schedule), optionally with Mip-Splatting's filters. RGB training is one user (targets = images);
// Stage II's latent fields are another (targets = normalised latents, background 0).
//
// Everything random is derived from (seed, step), so a run resumed from a checkpoint takes the same
// path as one that never stopped.
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include <torch/types.h>

#include "lrf/core/error.h"
#include "lrf/scene/camera.h"
#include "lrf/splat/train/densify.h"
#include "lrf/splat/gaussians.h"
#include "lrf/splat/train/optimizer.h"
#include "lrf/splat/raster/rasterize.h"

namespace lrf::splat {

struct TrainView {
  std::string name;
  Camera camera;
  torch::Tensor target;  // [C, H, W] float32, camera.height x camera.width
};

// A training objective other than the photometric loss against each view's target: given the render
// of view `view` ([C, H, W], under autograd) at the 1-based `step`, the scalar to minimise and, when
// cheap to know, a PSNR for the log. With one, the views' targets may have any shape (the objective
// decides what they mean); decoder-aware refinement is its user.
struct ObjectiveValue {
  torch::Tensor loss;
  double psnr = std::numeric_limits<double>::quiet_NaN();
  // Defined when the objective ran its own backward pass (through a decoder, say) down to the render: the
  // gradient of the loss in the render, which the trainer then carries on into the field. `loss` need not
  // be differentiable then; backward_ms is how long that pass took (part of the objective's call).
  torch::Tensor rendered_grad;
  double backward_ms = 0;
};
using Objective = std::function<ObjectiveValue(const torch::Tensor& rendered, int view, int64_t step)>;

struct TrainerOptions {
  int64_t iterations = 30000;
  int sh_degree = 3;  // the largest degree; training starts at 0 and adds one every schedule period
  bool mip = false;   // Mip-Splatting 3D smoothing filter + 2D Mip filter
  uint64_t seed = 0;
  double lambda_ssim = 0.2;
  torch::Tensor background;  // [C]; undefined = zeros
  LearningRates lr;
  DensifyOptions densify;
  DensifySchedule schedule;  // see DensifySchedule::for_iterations
  bool sparse_adam = false;  // skip Adam on rows without gradient (see GaussianAdam::sparse)
  // Adam updates each SH row as the render backward produces its gradient (GaussianAdam::sh_row_update),
  // without an [N, K, C] gradient tensor; the same result bit for bit. Off with sparse_adam.
  bool sh_update_in_backward = true;
  int psnr_every = 10;  // StepResult::psnr on the training view every this many steps (0 = never)
  Objective objective;  // empty: photometric_loss(render, view.target, lambda_ssim)
  // Called with the 1-based step right after the backward pass, before the Gaussians' Adam step: an
  // objective with parameters of its own (a decoder adapted with the field) updates them here.
  std::function<void(int64_t step)> after_backward;
  // The camera a step renders its view with (a refinement shifts it by a fraction of a pixel); empty: the
  // view's own.
  std::function<Camera(const Camera& camera, int view, int64_t step)> camera_of_step;
  // Coarse to fine: steps 1..coarse_until see every view at 1/coarse_factor of its width and height
  // (targets area-averaged, intrinsics scaled), the later ones at full resolution. A coarse step costs
  // about a quarter (factor 2), and the field may grow differently: fern's 7k RGB field grown on half-size
  // views has 195k Gaussians instead of 350k. 1: off. Photometric targets only (not with an objective).
  int coarse_factor = 1;
  int64_t coarse_until = 0;
};

// Where a step's time went, in milliseconds.
// loss: the objective's forward (a refinement's decode and image loss); loss_backward: an objective's own
// backward pass down to the render (ObjectiveValue::rendered_grad); backward: into the field (the whole
// backward when the objective runs none of its own); optimizer: the Gaussians' Adam; extra_optimizer:
// TrainerOptions::after_backward (a decoder's Adam).
struct StepTimings {
  double render = 0, loss = 0, backward = 0, optimizer = 0, densify = 0, loss_backward = 0, extra_optimizer = 0;
};

struct StepResult {
  int64_t step = 0;  // 1-based number of the step just done
  double loss = 0;
  double psnr = std::numeric_limits<double>::quiet_NaN();  // of this step's view, when computed
  int64_t gaussians = 0;
  bool densified = false;
  DensifyStats densify;
  StepTimings timings;
};

// Thrown when the loss or a parameter stops being finite.
class TrainingDiverged : public Error {
 public:
  TrainingDiverged(int64_t step, const std::string& what);
  int64_t step() const { return step_; }

 private:
  int64_t step_;
};

class Trainer {
 public:
  Trainer(std::vector<TrainView> views, Gaussians init, double extent, TrainerOptions options);

  StepResult step();
  bool done() const { return step_ >= options_.iterations; }
  int64_t steps_done() const { return step_; }
  int active_sh_degree() const;
  // The view (camera and target) that step `step` (1-based) trains on: views()[view] or, in the coarse
  // phase, its reduced copy.
  const TrainView& training_view(int view, int64_t step) const;
  const Gaussians& gaussians() const { return g_; }
  const TrainerOptions& options() const { return options_; }
  const std::vector<TrainView>& views() const { return views_; }
  double extent() const { return extent_; }

  // Renders the current field (filters applied) for any camera; without autograd unless `grad`.
  RenderOutput render(const Camera& camera, bool grad = false);
  // The field as a viewer should see it: with the Mip 3D filter baked into scales and opacities.
  Gaussians export_gaussians() const;
  // Throws TrainingDiverged when a parameter is NaN or infinite.
  void check_finite() const;

  // Checkpoint: parameters, optimizer moments, densification statistics, filter, step and seed.
  void save_checkpoint(const std::string& path) const;
  void load_checkpoint(const std::string& path);

 private:
  int view_for_step(int64_t step) const;
  bool coarse_at(int64_t step) const;
  RasterSettings settings(const Camera& camera) const;
  // render(); a step's render also hands its SH gradient rows to the optimizer through `sink`.
  RenderOutput render_with(const Camera& camera, bool grad, const ShGradientSink* sink);
  void update_filter();

  std::vector<TrainView> views_;
  std::vector<TrainView> coarse_views_;  // views_ at 1/coarse_factor, while a coarse phase is set
  Gaussians g_;
  double extent_;
  TrainerOptions options_;
  GaussianAdam adam_;
  Densifier densifier_;
  torch::Tensor filter_;  // [N] Mip 3D filter (std), defined when options_.mip
  int64_t step_ = 0;
};

}  // namespace lrf::splat
