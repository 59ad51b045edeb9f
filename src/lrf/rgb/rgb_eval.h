#pragma once
// Scoring an RGB field's test views: what `lrf eval` of an RGB run and the RGB rows of lrf compare and
// lrf pipeline write alike, so that one metrics.json has the same keys whichever made it.
#include <string>

#include <nlohmann/json.hpp>

namespace lrf {

struct RgbEvalOptions {
  std::string lpips_weights;  // LPIPS (VGG) weights; "" = no LPIPS ("lpips": null and "lpips_reason")
  double scale = 1.0;         // render and score at this multiple of the run's resolution (truth area-resized)
};

// Renders OUT's test views at `scale` times the resolution of its config's scene, scores them (PSNR,
// SSIM, MS-SSIM, FLIP, LPIPS), writes the renders as OUT/eval/*.png and the scores as OUT/metrics.json
// (the means, "views", "resolution", "scale", "gaussians", "render_fps", "storage_mb", and the training's
// "train_seconds" and "peak_memory_mb" when it finished) and returns them. Throws lrf::Error naming the
// file for a folder that holds no RGB field, lrf::UsageError for a scale outside render_size.h's bounds.
nlohmann::json evaluate_rgb_run(const std::string& out, const RgbEvalOptions& options = {});

}  // namespace lrf
