#pragma once
// What every kind's render_views shares: the views of a split, the folder they go to, and the rendered
// latents of the decoded kinds written beside their decoded images.
#include <functional>
#include <string>
#include <vector>

#include <torch/types.h>

#include "lrf/field_kinds/field_type.h"
#include "lrf/latent/latent_normalization.h"
#include "lrf/scene/scene.h"

namespace lrf {

class Autoencoder;

// The views of `request.split` (test, train or all); throws lrf::UsageError for another name and
// lrf::Error naming `run` when the split has none.
std::vector<int> split_views(const Scene& scene, const std::string& split, const std::string& run);

// request.dir, or RUN/renders/SPLIT; refused inside the scene's folders, created.
std::string renders_folder(const std::string& run, const ViewRenders& request, const Scene& scene);

// Each view's rendered latent (denormalised, one safetensors tensor "latent" [C, h, w]) and its decoded
// image, at the latent resolution the field was fitted at. `render_view(i)` gives view i's normalised latent.
int write_latent_views(const std::vector<int>& views, const Scene& scene, const LatentRange& range, Autoencoder& ae,
                       const std::function<torch::Tensor(int)>& render_view, const std::string& dir);

}  // namespace lrf
