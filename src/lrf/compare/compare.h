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

#include "lrf/autoencoder/latent_source.h"
#include "lrf/detail/detail_eval.h"
#include "lrf/points/initial_points.h"
#include "lrf/refine/refine.h"
#include "lrf/scene/scene.h"
#include "lrf/splat/run/scene_fit_options.h"

namespace lrf {

// What every method's field is fitted with (SceneFitOptions: the scene and its views, every method's steps,
// seed and initial points; out is compare's folder, force retrains every method), the latents
// (LatentSource) of every latent method, and compare's own settings.
struct CompareOptions : SceneFitOptions, LatentSource {
  CompareOptions() { iters = 7000; }
  // How every row is scored: the latent rows' decoder (also what latent-refined is refined through), LPIPS's
  // weights, and latent-refined+detail's pass (the detail pass on latent-refined's field).
  detail::DetailEvalOptions scoring;
  int latent_sh_degree = 1;  // kDefaultLatentShDegree (latent/latent_train_run.h)
  int64_t latent_iters = 0;  // 0 = iters
  int64_t nerf_iters = 0;  // latent-nerf steps (0 = nerf::kDefaultNerfIters; --steps counts Gaussian steps)
  std::vector<std::string> methods = {"rgb/8", "rgb/8-mip", "latent", "latent-refined"};
  RefineOptions refine;  // latent-refined: steps, crop, learning rates (run, out, decoder, seed are set here)
  int feature_dim = 0;   // feature-gs: features per Gaussian (0 = Feature 3DGS's default, half the latent channels)
  // Quality curves of other runs ("NAME=CSV", a curve.csv of lrf refine --score-every) drawn in the report
  // beside the latent-refined row's own (with --refine-score-every).
  std::vector<std::string> curves;
};

// Every method compare knows: rgb and rgb-mip (full resolution), rgb/8, rgb/8-mip, latent, latent-refined,
// latent-refined+detail (that field's frames with the detail pass), latent-nerf, feature-gs (a feature field lifted to the latent by a 1x1 convolution, after Feature 3DGS).
const std::vector<std::string>& compare_methods();

// Runs (or reuses) every method and writes OUT/table.csv, OUT/table.md and OUT/report.html.
nlohmann::json run_compare(const CompareOptions& options);

}  // namespace lrf
