#pragma once
// Training a latent NeRF into an output folder (nerf_run.h says what the folder holds and reopens it).
#include <cstdint>
#include <string>

#include "lrf/autoencoder/latent_source.h"
#include "lrf/splat/run/scene_fit_options.h"

namespace lrf::nerf {

// Steps of a latent NeRF unless told otherwise: about 50 minutes at 1 thread on fern at images_8 (63×47
// rays per view, 17 views) on the 2-core development machine, within the hour the efficiency table allows it.
constexpr int64_t kDefaultNerfIters = 10000;

// The field's shape and sampling, fixed when a run starts (also lrf train's request).
struct NerfFitSettings {
  int rays = 1024;       // rays per step
  int samples = 32;      // coarse samples per ray, and as many fine ones
  int log2_table = 17;   // hash table entries per level: 2^log2_table
};

// scene_options (SceneFitOptions): the image folder, downscale, test split and few-shot training views
// (train_views: K evenly spaced training views; 0 = all), as for latent Gaussian fields: cropped to multiples
// of 8, no test list. init_points: the points that bound the scene (SfM, triangulated, a file).
struct LatentNerfOptions : SceneFitOptions, LatentSource, NerfFitSettings {
  LatentNerfOptions() { iters = kDefaultNerfIters; }
};

struct LatentNerfResult {
  int64_t steps = 0, parameters = 0;
  double seconds = 0, encode_seconds = 0, final_loss = 0;
};

LatentNerfResult train_latent_nerf(const LatentNerfOptions& options);

// The options the run in OUT was started with (for --resume); throws lrf::Error naming config.json.
LatentNerfOptions recorded_nerf_options(const std::string& out);

}  // namespace lrf::nerf
