#pragma once
// Scoring any field that renders normalised latents (a latent Gaussian field, a latent NeRF): each test
// view's rendered latent is decoded and scored against the real image (PSNR, SSIM, MS-SSIM, FLIP, LPIPS
// when weights are given), beside the autoencoder's own round trip of that view (the ceiling) and the
// latent-space PSNR against the encoded view. What the field is and how it renders is the caller's.
#include <functional>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>
#include <torch/types.h>

#include "lrf/autoencoder/autoencoder.h"
#include "lrf/eval/lpips.h"
#include "lrf/latent/latent_normalization.h"
#include "lrf/scene/scene.h"

namespace lrf {

struct LatentScoring {
  const Scene* scene = nullptr;      // at the training resolution, cropped to multiples of 8
  const LatentRange* range = nullptr;
  Autoencoder* autoencoder = nullptr;  // with the decoder to score through
  std::string autoencoder_identity;    // of the encoder (for the cache of encoded test views)
  const Lpips* lpips = nullptr;        // null: no LPIPS
  std::string image_dir;               // decoded test views are written here as PNG ("" = not written)
  // The normalised latent [C, h/8, w/8] of view i.
  std::function<torch::Tensor(int view)> render;
};

// Per-view and mean scores: {psnr, ssim, ms_ssim, flip, lpips, views: [...], roundtrip_psnr, latent_psnr,
// resolution, latent_resolution, render_fps, decode_fps}.
nlohmann::json score_latent_test_views(const LatentScoring& scoring);

// LPIPS from the weights at `weights`, or none when the path is empty.
std::optional<Lpips> load_lpips_if_given(const std::string& weights);

// Why a metrics record without LPIPS has none.
extern const char* const kNoLpipsReason;

// The training time and peak memory that a run's config.json records under "result", copied into metrics
// (0 where the run did not record them) for the efficiency table.
void add_training_cost(nlohmann::json& metrics, const nlohmann::json& config);

}  // namespace lrf
