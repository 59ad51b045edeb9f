#pragma once
// What the kinds' implementations share: the views of a split, the folder they go to, and what the kinds
// decoded from latents do alike (their views' latents written beside their decoded images, their scoring).
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <torch/types.h>

#include "lrf/field_kinds/field_type.h"
#include "lrf/latent/latent_normalization.h"
#include "lrf/latent/latent_run.h"
#include "lrf/scene/scene.h"

namespace lrf {

class Autoencoder;

// The views of `split` (test, train or all); throws lrf::UsageError for another name and
// lrf::Error naming `run` when the split has none.
std::vector<int> split_views(const Scene& scene, const std::string& split, const std::string& run);

// request.dir, or RUN/renders/SPLIT; refused inside the scene's folders, created.
std::string renders_folder(const std::string& run, const ViewRenders& request, const Scene& scene);

// render_views of a kind decoded from latents (latent fields, latent NeRFs): refuses a scale or size (they
// render at their latent resolution and decode at 8x), then writes each view's rendered latent (denormalised,
// one safetensors tensor "latent" [C, h, w]) and its decoded image. `load_autoencoder` gives the decoder to
// use, `render_view(i)` view i's normalised latent.
int write_decoded_views(const std::string& run, const ViewRenders& request, const Scene& scene,
                        const LatentRange& range, const std::function<std::unique_ptr<Autoencoder>()>& load_autoencoder,
                        const std::function<torch::Tensor(int)>& render_view);

// How a decoded kind is scored: the decoder and LPIPS weights asked for; refuses --scale (such fields are
// scored at 8x their latent size).
LatentEvalOptions decoded_eval_options(const FieldScoring& scoring);

}  // namespace lrf
