#pragma once
// Stage I: correspondence-aware fine-tuning of an autoencoder's encoder (the paper's Method,
// "Correspondence-aware Autoencoding"; DESIGN.md §7). The decoder stays frozen; the loss is
//   L_VAE + lambda1 * L_corres + lambda2 * L_reg
// with every term a per-element mean so the lambdas do not depend on crop or batch size:
//   L_VAE    mean |D(E(x)) - x| over pixels (KL-VAE: decoded from a posterior sample, plus kl_weight times
//            the KL to N(0, I), scaled like ldm's: its per-image sums divided by the pixel count),
//   L_corres sum over the batch's pairs of lambda_ij * mean |z_i(x_i) - z_j(x_j)|, lambda_ij the pair's
//            APE share (sums to 1), latents sampled bilinearly at pixel / 8,
//   L_reg    mean (z - z_orig)^2 for a deterministic encoder; for the KL-VAE the mean per-element
//            KL(q_new || q_orig) between the diagonal Gaussian posteriors.
#include <cstdint>
#include <string>
#include <vector>

#include <ATen/Tensor.h>
#include <nlohmann/json.hpp>

#include "lrf/autoencoder/autoencoder.h"
#include "lrf/core/run_control.h"
#include "lrf/distributed/distributed_options.h"
#include "lrf/finetune/finetune_loop.h"
#include "lrf/finetune/pair_batches.h"
#include "lrf/scene/scene_spec.h"

namespace lrf {

// out (RunControl): the fine-tuned encoder (.safetensors).
struct EncoderFinetuneOptions : RunControl {
  EncoderFinetuneOptions() { checkpoint_every = 50; }
  std::vector<std::string> scenes;
  std::vector<std::string> correspondence_files;  // optional, one per scene
  // Optional, one per scene: its image folder and downscale (0: from max_side), for scenes that each need
  // their own (lrf pipeline's PATH:--images=DIR). Recorded only when given, so earlier records still match.
  std::vector<SceneResolution> scene_resolutions;
  std::string autoencoder = "taef2", encoder;     // model and an optional starting encoder
  int max_side = 640;                             // scenes are downscaled so their longer side fits
  int min_matches = 15;                           // pairs with fewer correspondences are dropped
  PairBatchOptions batch;
  int64_t steps = 300;
  // lambda_reg 3: on llff-fern (unseen), TAEF2 trained on fox + beer-can lost 1.9 dB of round trip by step 80
  // with 1, and gained only 10 % consistency in 100 steps with 10; 3 gave -27 % at -1.0 dB after 300 steps.
  double lambda_corres = 1.0, lambda_reg = 3.0, kl_weight = 1e-6;
  double base_lr = 4.5e-6;  // the paper's base rate; the Adam rate is base_lr x images per step ...
  double lr = 0;            // ... unless this is set (> 0)
  uint64_t seed = 0;
  // Data parallelism: batch.pairs stays the global batch, split over the ranks (world size 1: one process).
  DistributedOptions distributed{0, 1, 0, "127.0.0.1", 29500};
};

struct Stage1Losses {
  at::Tensor total, vae, corres, reg;  // scalars; total carries the gradient
};

// The loss of one batch. `original` is the frozen starting autoencoder (for L_reg).
Stage1Losses stage1_losses(Autoencoder& model, Autoencoder& original, const PairBatch& batch,
                           const EncoderFinetuneOptions& options);
// This rank's part of the loss of the global `batch`: the pairs of `share` (counted in pairs), each term
// scaled so that the mean of the ranks' parts is the global batch's term (the correspondence term keeps
// the APE weights of the whole batch; a KL-VAE's posterior noise is drawn for the whole batch and sliced).
Stage1Losses stage1_losses(Autoencoder& model, Autoencoder& original, const PairBatch& batch,
                           const EncoderFinetuneOptions& options, const BatchShare& share);

struct EncoderFinetuneResult {
  bool main_rank = true;  // false on the ranks that write nothing
  int64_t steps = 0;
  double seconds = 0, sync_seconds = 0;  // sync: waiting on the other ranks (see FinetuneLoopResult)
  double total_seconds = 0;              // over every session that made the steps (FinetuneLoopResult)
  double last_total = 0, last_vae = 0, last_corres = 0, last_reg = 0;
};

// Runs Stage I to options.steps, checkpointing to checkpoint_path(out) and writing the encoder to `out`
// (plus `out` with .json: the run record) atomically at the end.
EncoderFinetuneResult finetune_encoder(const EncoderFinetuneOptions& options);

// The options as recorded in OUT.json (under "options") and compared when a pipeline reuses a run.
nlohmann::json encoder_finetune_options_json(const EncoderFinetuneOptions& options);

// OUT.checkpoint.safetensors: the encoder, Adam's moments and the step.
std::string finetune_checkpoint_path(const std::string& out);
// OUT without its extension + ".json".
std::string finetune_record_path(const std::string& out);

}  // namespace lrf
