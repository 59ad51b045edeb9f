#pragma once
// Training a feature field (`lrf train --space latent --feature-dim D`, compare's feature-gs row) with the
// Stage II machinery: the same views, normalised latent targets, initial points, schedule and densification
// as a latent field; only what the Gaussians carry and what is compared with the targets differ. The
// trainer renders the D-channel feature map at latent resolution, the objective lifts it to the C latent
// channels (feature_lift.h) and applies the latent field's loss (0.8 L1 + 0.2 D-SSIM) against the
// normalised latent; the lift takes an Adam step after every backward pass, as Feature 3DGS's decoder does.
//
// The lift's state lives beside the field's checkpoint: OUT/lift.checkpoint.safetensors (weights, Adam
// moments, step count) and the one before it, OUT/lift.checkpoint.previous.safetensors; OUT/lift.safetensors
// holds the weights `eval` and `render` use. The lift's checkpoint of a step is written right after that
// step's backward pass, before the field's own checkpoint, and the previous one is kept: a job killed
// between the two writes still finds the lift of the field's last checkpoint, so resuming is exact.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <ATen/Tensor.h>

#include "lrf/feature/feature_lift.h"
#include "lrf/optim/param_adam.h"
#include "lrf/splat/gaussians.h"
#include "lrf/splat/run/train_run.h"
#include "lrf/splat/train/trainer.h"

namespace lrf {

// Feature 3DGS's rates: its semantic features move at 0.001 (Adam, on the value; here on the SH DC
// coefficient the rasterizer turns into the rendered feature), its 1x1 decoder at 0.0001.
constexpr double kFeatureLearningRate = 1e-3;
constexpr double kLiftLearningRate = 1e-4;

// The starting feature field: the latent field's starting Gaussians (the same points, shapes and
// opacities), with every one of the D features at 0.5, the value of a zero SH coefficient. Feature 3DGS
// starts its features at zero, which its rasterizer renders as zero; lrf's renders C0 * dc + 0.5 clamped at
// 0, where 0 would sit on the clamp and receive no gradient, so the neutral start is the SH zero.
splat::Gaussians feature_field_start(const splat::Gaussians& latent_start, int feature_dim);

class FeatureLiftTraining {
 public:
  // `out` is the run folder; checkpoints follow the run's checkpoint_every and its last step.
  FeatureLiftTraining(FeatureLift lift, double lr, std::string out, int64_t checkpoint_every, int64_t iterations);
  // The hooks it attaches point at this object.
  FeatureLiftTraining(const FeatureLiftTraining&) = delete;
  FeatureLiftTraining& operator=(const FeatureLiftTraining&) = delete;

  const FeatureLift& lift() const { return lift_; }

  // Sets the trainer's objective (the lifted render against targets[view], the normalised latent of that
  // training view, with 3DGS's loss mix), the features' rates and the lift's step after each backward pass.
  void attach(splat::TrainerOptions& trainer_options, std::vector<at::Tensor> targets, double lambda_ssim);
  // Makes run_training save OUT/lift.safetensors with the field and restore the lift on resume.
  void attach(splat::RunOptions& run_options, const splat::Trainer& trainer);

  // One Adam step from the lift's gradients (then cleared); at checkpoint steps, the lift's checkpoint.
  void step(int64_t step);
  // Restores the lift's checkpoint of `step` (the field's checkpoint step); throws lrf::Error naming the
  // checkpoint when neither file holds that step.
  void restore(int64_t step);
  // OUT/lift.safetensors.
  void save_weights() const;
  // A fresh run (not resumed) removes the lift checkpoints of an earlier run in OUT.
  void remove_checkpoints() const;

  static std::string weights_path(const std::string& out);
  static std::string checkpoint_path(const std::string& out);
  static std::string previous_checkpoint_path(const std::string& out);

 private:
  bool checkpoint_step(int64_t step) const;

  FeatureLift lift_;
  std::unique_ptr<ParamAdam> adam_;
  std::string out_;
  int64_t checkpoint_every_, iterations_;
};

}  // namespace lrf
