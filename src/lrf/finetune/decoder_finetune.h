#pragma once
// Stage III: VAE-radiance-field alignment (the paper's Method, DESIGN.md §8). Fitted latent fields
// render latents for their training views and for their held-out views; these are distributed unlike
// encoded latents (blur, floaters, view-dependent leftovers), so only the decoder is fine-tuned to turn
// them into the real images:
//   loss = weight_train * mean |D(Z_train) - I_train| + weight_novel * mean |D(Z_novel) - I_novel|
// (the paper's), or with lambda_ssim > 0 each term mixed with D-SSIM as 3DGS does, (1 - lambda) L1 +
// lambda (1 - SSIM): a structure-aware term for the decoder that sharpens edges the fields place a little off
// (a lever of Stage III's to measure; the paper's loss is the default). With weight_roundtrip > 0 a third
// term, on crops of the training images encoded by the (frozen) encoder, keeps the decoder decoding ordinary
// latents: on validation splits the paper's loss made the round trip 6-9 dB worse on scenes unlike the
// training scenes (docs/results.md), the decoder drifting rather than learning the fields' artefacts.
// on random aligned crops (latent crop c/8, image crop c at 8x the offset), on the decoder's output before
// its [0, 1] clamp: through the clamp a pixel decoded past 0 or 1 would get no gradient back (measured on
// fern in an earlier branch: 20.60 -> 21.02 dB with the unclamped loss, same schedule).
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lrf/core/run_control.h"
#include "lrf/distributed/distributed_options.h"

namespace lrf {

// The round-trip weight lrf's commands (finetune-decoder, pipeline, demo) use unless told otherwise; the
// options below keep the paper's loss (0). Chosen on validation splits of fern, flower and room (their
// training views only), decoders trained on seven other scenes: weights 0 / 0.5 / 1 / 2 / 4 gave a mean
// 20.91 / 21.72 / 21.78 / 21.81 / 21.87 dB and FLIP 0.280 / 0.238 / 0.232 / 0.226 / 0.220, the stock decoder
// 21.47 dB and 0.217 (docs/results.md, "Stage III with seven training scenes, on validation splits").
constexpr double kRecommendedWeightRoundtrip = 4;

// out (RunControl): the fine-tuned decoder (.safetensors).
struct DecoderFinetuneOptions : RunControl {
  DecoderFinetuneOptions() { checkpoint_every = 50; }
  std::vector<std::string> fields;             // finished latent runs (`lrf train --space latent`)
  std::string autoencoder = "taef2", encoder;  // must be what every field was trained with
  std::string decoder;                         // start from this decoder ("" = the autoencoder's)
  int64_t steps = 300;
  int batch = 2;                 // crops per step from training views, and as many from held-out views
  int crop = 128;                // image crop side (multiple of 8), reduced to fit the smallest view
  double weight_train = 0.5, weight_novel = 0.5;
  double lambda_ssim = 0;        // 0 = the paper's pure L1
  double weight_roundtrip = 0;   // weight of the encoded-image term (0 = none, the paper's loss; its crops do
                                 // not count in the base rate's crops per step)
  double base_lr = 4.5e-6;       // the paper's base rate; Adam's rate is base_lr x crops per step ...
  double lr = 0;                 // ... unless this is set (> 0)
  uint64_t seed = 0;
  // Data parallelism: batch stays the global batch, split over the ranks (world size 1: one process).
  DistributedOptions distributed{0, 1, 0, "127.0.0.1", 29500};
};

struct DecoderFinetuneResult {
  bool main_rank = true;  // false on the ranks that write nothing
  int64_t steps = 0, train_samples = 0, novel_samples = 0;
  double seconds = 0, last_loss = 0, last_train = 0, last_novel = 0;
  double total_seconds = 0;  // over every session that made the steps (FinetuneLoopResult)
};

DecoderFinetuneResult finetune_decoder(const DecoderFinetuneOptions& options);

nlohmann::json decoder_finetune_options_json(const DecoderFinetuneOptions& options);
// OUT.checkpoint.safetensors and OUT without its extension + ".json" (the run record).
std::string decoder_checkpoint_path(const std::string& out);
std::string decoder_record_path(const std::string& out);

}  // namespace lrf
