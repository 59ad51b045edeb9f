#pragma once
// How every fit to a scene's latents begins (a latent Gaussian field, a latent NeRF): the scene at a
// resolution the autoencoder divides (centre-cropped to multiples of 8), the autoencoder, and the
// training views encoded once, through the latent cache.
#include <memory>
#include <string>
#include <vector>

#include <torch/types.h>

#include "lrf/autoencoder/autoencoder.h"
#include "lrf/scene/scene.h"

namespace lrf {

struct EncodedSceneRequest {
  std::string scene;        // folder
  SceneOptions options;     // image folder, downscale, test split, few-shot K (cropped to multiples of 8 here)
  std::string autoencoder;  // name or path
  std::string encoder;      // fine-tuned encoder weights ("" = stock)
  std::string cache_dir;    // "" = default_cache_dir()
};

struct EncodedScene {
  SceneOptions options;  // as the scene was loaded (recorded in run configs)
  Scene scene;
  std::unique_ptr<Autoencoder> autoencoder;
  std::string autoencoder_identity;
  std::vector<torch::Tensor> latents;  // raw [C, H/8, W/8], one per training view, in train_indices order
  double encode_seconds = 0;           // 0-ish when the cache already held them
};

// Fails naming the scene when it has no training views.
EncodedScene load_encoded_scene(const EncodedSceneRequest& request);

// Throws lrf::UsageError when `options` ask for what latent runs (`--space` `space`) do not read yet: a test
// list or a forced format. Called by each job before it creates its output.
void require_latent_scene_options(const SceneOptions& options, const std::string& space);

}  // namespace lrf
