#pragma once
// Stage II runs on disk: reopening a latent field's folder to render latents, decode them and score the
// decoded test views (training one: latent_train_run.h).
//
// OUT/config.json records the scene, resolution, autoencoder (and encoder override), the latent range and
// the training options; OUT/point_cloud.ply holds the field with C = latent channels. A feature field
// (--feature-dim D) holds D channels there, records "feature_dim": D, and keeps its lift in
// OUT/lift.safetensors.
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "lrf/autoencoder/autoencoder.h"
#include "lrf/feature/feature_lift.h"
#include "lrf/latent/latent_normalization.h"
#include "lrf/scene/scene.h"
#include "lrf/splat/gaussians.h"
#include "lrf/splat/render_field.h"

namespace lrf {

struct LatentRun {
  std::string out;
  nlohmann::json config;
  Scene scene;  // at the training resolution, cropped to multiples of 8
  splat::Gaussians field;
  splat::FieldRenderOptions render;
  LatentRange range;
  std::string autoencoder, encoder;
  std::string decoder;  // the decoder a refined field was fitted through ("" = the autoencoder's)
  FeatureLift lift;     // a feature field's 1x1 convolution (undefined for a latent field)
};

// Opens OUT; throws lrf::Error naming the file when it is not a finished latent run, or when the scene
// or the autoencoder's files changed since training (the field would not match them).
LatentRun open_latent_run(const std::string& out);

// Renders view i's normalised latent [C, h, w] (latent resolution of the training camera); a feature
// field's rendered features are lifted to the latent channels first.
torch::Tensor render_latent(const LatentRun& run, int view);
// The same for any camera at latent resolution (latent_camera of an image camera).
torch::Tensor render_latent_at(const LatentRun& run, const Camera& latent_camera);

struct LatentEvalOptions {
  std::string decoder;        // decoder override (Stage III) ("" = the run's own: see LatentRun::decoder)
  std::string lpips_weights;  // "" = LPIPS not computed ("lpips": null with the reason)
  bool write_images = true;   // <output_dir>/eval/<name>.png decoded test views
  std::string output_dir;     // where metrics.json and eval/ go ("" = the run folder OUT)
};

// Scores the decoded test views against the real images (at 8x the latent size): PSNR, SSIM, LPIPS, plus
// the autoencoder's round-trip PSNR on the same views (the ceiling) and the latent-space PSNR of the
// rendered latents against the encoded test views; writes metrics.json (in options.output_dir, default OUT)
// and returns it.
nlohmann::json evaluate_latent_run(const std::string& out, const LatentEvalOptions& options);

}  // namespace lrf
