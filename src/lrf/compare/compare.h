#pragma once
// The paper's Table 1 on one scene: image-space baselines at latent resolution (3DGS/8 and
// Mip-Splatting/8: RGB fields trained on the views downscaled 8x and rendered at full resolution) and the
// latent field with the stock autoencoder (3DGS-VAE), all scored on the same test views at the same
// resolution; a CSV / markdown table and a self-contained HTML report.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lrf/scene/scene.h"

namespace lrf {

struct CompareOptions {
  std::string scene, out, images, autoencoder = "taef2", encoder, decoder, lpips_weights, cache_dir;
  int downscale = 1, test_every = 8, latent_sh_degree = 0;
  int64_t iters = 7000, latent_iters = 0;  // latent_iters 0 = iters
  uint64_t seed = 0;
  std::vector<std::string> methods = {"rgb/8", "rgb/8-mip", "latent"};
  bool force = false;
};

// Trains an RGB field on the views of `scene` (cropped to multiples of 8) downscaled 8x; the run's
// config describes the full-resolution scene, so `lrf render/eval OUT` work at full resolution.
void train_rgb_at_latent_resolution(const std::string& scene_root, const SceneOptions& so, const std::string& out,
                                    int64_t iters, bool mip, uint64_t seed, bool resume);

// Scores an RGB run's test views at the resolution of its config's scene; writes OUT/eval/*.png and
// OUT/metrics.json (psnr, ssim, lpips, views, render_fps, gaussians, storage_mb, train_seconds).
nlohmann::json evaluate_rgb_run(const std::string& out, const std::string& lpips_weights);

// Runs (or reuses) every method and writes OUT/table.csv, OUT/table.md and OUT/report.html.
nlohmann::json run_compare(const CompareOptions& options);

}  // namespace lrf
