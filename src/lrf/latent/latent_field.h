#pragma once
// Stage II: a radiance field whose features are normalised latent vectors. Training targets are the
// encoded training views (normalised per channel with the training range), rendered at latent
// resolution (image / 8) with background 0; rendering maps the field's output back to raw latents and
// decodes them into images at 8x the latent size.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <torch/types.h>

#include "lrf/autoencoder/autoencoder.h"
#include "lrf/latent/latent_normalization.h"
#include "lrf/points/initial_points.h"
#include "lrf/scene/scene.h"
#include "lrf/splat/gaussians.h"
#include "lrf/splat/train/trainer.h"

namespace lrf {

// A camera at image resolution seen at latent resolution (both sizes are multiples of 8).
Camera latent_camera(const Camera& image_camera, int factor = 8);

enum class LatentInit { latents, rgb };
LatentInit parse_latent_init(const std::string& name);

struct LatentTrainingData {
  std::vector<splat::TrainView> views;  // latent cameras, normalised latent targets
  LatentRange range;
  splat::Gaussians init;
  std::string init_description;
  nlohmann::json init_points;  // where the initial points came from (InitialPoints::record), for config.json
};

// Builds the training views and the starting field from the training views' raw latents, on the points
// that choose_initial_points picks with `points`. rgb_guide > 0 appends 3 channels to every target: the
// view's image area-downsampled to latent resolution, times rgb_guide (features started from the same
// images). Unlike the stock encoder's latents these colours agree across views, so the geometry fitted
// to both generalises better; the channels serve training only (the caller drops them from the field).
LatentTrainingData prepare_latent_training(const Scene& scene, const std::vector<torch::Tensor>& train_latents,
                                           LatentInit init, int sh_degree, uint64_t seed,
                                           const InitPointsOptions& points = InitPointsOptions{},
                                           double rgb_guide = 0);

// Decodes a normalised latent [C, h, w] from a field: denormalise (clamped) then decode -> [3, 8h, 8w].
torch::Tensor decode_normalised(Autoencoder& ae, const LatentRange& range, const torch::Tensor& normalised);

}  // namespace lrf
