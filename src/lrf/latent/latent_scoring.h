#pragma once
// Scoring any field that renders normalised latents (a latent Gaussian field, a latent NeRF): each test
// view's rendered latent is decoded and scored against the real image (PSNR, SSIM, MS-SSIM, FLIP, LPIPS
// when weights are given), beside the autoencoder's own round trip of that view (the ceiling) and the
// latent-space PSNR against the encoded view. What the field is and how it renders is the caller's.
#include <functional>
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

struct LatentEvalOptions;  // lrf/latent/latent_run.h

// What `lrf eval` does alike for every latent run (a Gaussian field, a NeRF): the test views rendered by
// `render` and decoded through `decoder` ("" = the autoencoder's own), scored as above, with LPIPS when
// options.lpips_weights is given. Creates the result folder (options.output_dir, default `out`) and
// returns the scores with "decoder" (and "lpips_reason" without LPIPS); writes nothing yet.
nlohmann::json score_latent_run(const std::string& out, const Scene& scene, const LatentRange& range,
                                const std::string& autoencoder, const std::string& encoder,
                                const std::string& decoder, const LatentEvalOptions& options,
                                const std::function<torch::Tensor(int view)>& render);

// Completes and writes metrics.json into the result folder: the training time and peak memory that the
// run's config records under "result", the stamp of `field_file` (which version of the field the scores
// belong to, so that a reused score can be checked against it) and how the scores were made.
void write_latent_run_metrics(const std::string& out, const LatentEvalOptions& options, const nlohmann::json& config,
                              const std::string& field_file, nlohmann::json& metrics);

}  // namespace lrf
