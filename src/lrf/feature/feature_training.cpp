#include "lrf/feature/feature_training.h"

#include <filesystem>

#include <ATen/ATen.h>

#include "lrf/core/error.h"
#include "lrf/core/safetensors.h"
#include "lrf/splat/train/loss.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {

constexpr const char* kCheckpointKind = "feature-lift-checkpoint";

// The step a lift checkpoint holds, or -1 when `path` is missing or not a lift checkpoint.
int64_t checkpoint_step_of(const std::string& path) {
  if (!fs::exists(path)) return -1;
  const auto meta = read_safetensors_metadata(path);
  const auto kind = meta.find("lrf_kind");
  const auto steps = meta.find("lrf_adam_steps");
  if (kind == meta.end() || kind->second != kCheckpointKind || steps == meta.end()) return -1;
  try {
    return std::stoll(steps->second);
  } catch (const std::exception&) {
    return -1;
  }
}

}  // namespace

splat::Gaussians feature_field_start(const splat::Gaussians& latent_start, int feature_dim) {
  if (feature_dim < 1 || feature_dim > kMaxFeatureDim)
    fail_usage("--feature-dim must be 1.." + std::to_string(kMaxFeatureDim) + ", got " + std::to_string(feature_dim));
  splat::Gaussians g = latent_start.clone();
  g.sh = at::zeros({g.size(), g.sh.size(1), feature_dim}, at::kFloat);
  g.make_leaves();
  return g;
}

FeatureLiftTraining::FeatureLiftTraining(FeatureLift lift, double lr, std::string out, int64_t checkpoint_every,
                                         int64_t iterations)
    : lift_(std::move(lift)), out_(std::move(out)), checkpoint_every_(checkpoint_every), iterations_(iterations) {
  if (!(lr > 0)) fail_usage("--lift-lr must be positive");
  adam_ = std::make_unique<ParamAdam>(lift_.parameters(), AdamOptions{lr});
}

std::string FeatureLiftTraining::weights_path(const std::string& out) {
  return (fs::path(out) / "lift.safetensors").string();
}
std::string FeatureLiftTraining::checkpoint_path(const std::string& out) {
  return (fs::path(out) / "lift.checkpoint.safetensors").string();
}
std::string FeatureLiftTraining::previous_checkpoint_path(const std::string& out) {
  return (fs::path(out) / "lift.checkpoint.previous.safetensors").string();
}

bool FeatureLiftTraining::checkpoint_step(int64_t step) const {
  // The steps after which run_training saves the field: every checkpoint_every, and the last.
  return step == iterations_ || (checkpoint_every_ > 0 && step % checkpoint_every_ == 0);
}

void FeatureLiftTraining::attach(splat::TrainerOptions& to, std::vector<at::Tensor> targets, double lambda_ssim) {
  to.lr.sh_dc = kFeatureLearningRate;
  to.lr.sh_rest = kFeatureLearningRate / 20.0;  // 3DGS's ratio, for fields given an SH degree above 0
  const int psnr_every = to.psnr_every;
  to.objective = [this, targets = std::move(targets), lambda_ssim, psnr_every](const at::Tensor& rendered, int view,
                                                                               int64_t step) {
    const at::Tensor& target = targets.at(static_cast<size_t>(view));
    const at::Tensor lifted = lift_.apply(rendered);
    splat::ObjectiveValue v;
    v.loss = splat::photometric_loss(lifted, target, lambda_ssim);
    if (psnr_every > 0 && step % psnr_every == 0) v.psnr = splat::psnr(lifted.detach(), target);
    return v;
  };
  to.after_backward = [this](int64_t step) { this->step(step); };
}

void FeatureLiftTraining::attach(splat::RunOptions& ro, const splat::Trainer& trainer) {
  ro.save_extra = [this] { save_weights(); };
  ro.load_extra = [this, &trainer] { restore(trainer.steps_done()); };
}

void FeatureLiftTraining::step(int64_t step) {
  adam_->step();
  adam_->zero_grad();
  if (adam_->steps() != step) {
    fail(checkpoint_path(out_), "the lift has taken " + std::to_string(adam_->steps()) + " steps at the field's step " +
                                    std::to_string(step));
  }
  if (!checkpoint_step(step)) return;
  const std::string current = checkpoint_path(out_), previous = previous_checkpoint_path(out_);
  std::error_code ec;
  if (fs::exists(current)) fs::rename(current, previous, ec);
  if (ec) fail(current, "cannot keep the previous lift checkpoint: " + ec.message());
  adam_->save(current, {{"lrf_kind", kCheckpointKind}});
}

void FeatureLiftTraining::restore(int64_t step) {
  const std::string current = checkpoint_path(out_), previous = previous_checkpoint_path(out_);
  for (const auto& path : {current, previous}) {
    if (checkpoint_step_of(path) != step) continue;
    adam_->load(path);
    return;
  }
  fail(current, "no lift checkpoint of step " + std::to_string(step) + " (the field's checkpoint step) here or in " +
                    previous + " (found steps " + std::to_string(checkpoint_step_of(current)) + " and " +
                    std::to_string(checkpoint_step_of(previous)) + "; -1: none): retrain with --force");
}

void FeatureLiftTraining::save_weights() const { lift_.save(weights_path(out_)); }

void FeatureLiftTraining::remove_checkpoints() const {
  std::error_code ec;
  fs::remove(checkpoint_path(out_), ec);
  fs::remove(previous_checkpoint_path(out_), ec);
}

}  // namespace lrf
