#pragma once
// Stage II encodes every view once. The latents are cached on disk, keyed by everything they depend on:
// the scene folder, each view's image file (size and modification time), the resolution and crop, and
// the autoencoder's weight files (path, size, modification time), fine-tuned encoder and precision (fp32
// or bf16; the file holds float32 latents either way). A change to any
// of them is a different key; a cache file whose recorded key differs or that cannot be read is
// rebuilt with a warning.
#include <string>
#include <vector>

#include <torch/types.h>

#include "lrf/autoencoder/autoencoder.h"
#include "lrf/core/cache_key.h"  // default_cache_dir()
#include "lrf/scene/scene.h"

namespace lrf {

// A stable description of the files an autoencoder was loaded from (for cache keys and run records).
std::string autoencoder_identity(const std::string& name_or_path, const std::string& encoder_override);

// A stable description of one weights file (path, size, modification time), e.g. a refined field's decoder.
std::string weights_file_identity(const std::string& path);

struct LatentCacheResult {
  std::vector<torch::Tensor> latents;  // raw [C, H/8, W/8] float32, one per requested view
  std::string path;                    // cache file used
  bool hit = false;
};

// Encodes views `indices` of `scene` (whose cameras must be multiples of 8: load with
// crop_to_multiple_of_8) with `ae`, through the cache in `cache_dir` ("" disables the cache).
LatentCacheResult encode_views_cached(const Scene& scene, const std::vector<int>& indices, Autoencoder& ae,
                                      const std::string& ae_identity, const std::string& cache_dir);

}  // namespace lrf
