#pragma once
// Which latents a job works in: the autoencoder (a name under the models folder, or a path), a fine-tuned
// encoder in place of its own (Stage I; "" = the autoencoder's), and where encoded views are cached
// ("" = $LRF_CACHE or ~/.cache/lrf). Every latent job's options derive from it.
#include <string>

namespace lrf {

struct LatentSource {
  std::string autoencoder = "taef2", encoder, cache_dir;
};

}  // namespace lrf
