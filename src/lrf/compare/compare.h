#pragma once
// The paper's Table 1 on one scene: image-space baselines at latent resolution (3DGS/8 and
// Mip-Splatting/8: RGB fields trained on the views downscaled 8x and rendered at full resolution), the
// full-resolution RGB field, the latent field with the stock autoencoder (3DGS-VAE) and that field refined
// through the decoder (lrf refine), a NeRF fitted to the same latents (Latent-NeRF*), the Feature-GS
// baseline (src/lrf/feature/), all scored on the same test views at the same resolution; a CSV / markdown
// table and a self-contained HTML report.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lrf/detail/detail_blend.h"
#include "lrf/points/initial_points.h"
#include "lrf/refine/refine.h"
#include "lrf/scene/scene.h"

namespace lrf {

struct CompareOptions {
  std::string scene, out, images, autoencoder = "taef2", encoder, decoder, lpips_weights, cache_dir;
  int downscale = 1, test_every = 8;
  int latent_sh_degree = 1;  // kDefaultLatentShDegree (latent/latent_run.h)
  int train_views = 0;  // few-shot: K evenly spaced training views for every method (0 = all)
  int64_t iters = 7000, latent_iters = 0;  // latent_iters 0 = iters
  int64_t nerf_iters = 0;  // latent-nerf steps (0 = nerf::kDefaultNerfIters; --steps counts Gaussian steps)
  uint64_t seed = 0;
  std::vector<std::string> methods = {"rgb/8", "rgb/8-mip", "latent", "latent-refined"};
  InitPointsOptions init_points;  // every method starts from the same points
  RefineOptions refine;  // latent-refined: steps, crop, learning rates (run, out, decoder, seed are set here)
  detail::DetailOptions detail;  // latent-refined+detail: the detail pass on latent-refined's field
  int feature_dim = 0;   // feature-gs: features per Gaussian (0 = Feature 3DGS's default, half the latent channels)
  // Quality curves of other runs ("NAME=CSV", a curve.csv of lrf refine --score-every) drawn in the report
  // beside the latent-refined row's own (with --refine-score-every).
  std::vector<std::string> curves;
  bool force = false;
};

// Every method compare knows: rgb and rgb-mip (full resolution), rgb/8, rgb/8-mip, latent, latent-refined,
// latent-refined+detail (that field's frames with the detail pass), latent-nerf, feature-gs (a feature field lifted to the latent by a 1x1 convolution, after Feature 3DGS).
const std::vector<std::string>& compare_methods();

// Runs (or reuses) every method and writes OUT/table.csv, OUT/table.md and OUT/report.html.
nlohmann::json run_compare(const CompareOptions& options);

}  // namespace lrf
