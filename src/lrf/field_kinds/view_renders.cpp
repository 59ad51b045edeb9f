#include "lrf/field_kinds/view_renders.h"

#include <filesystem>

#include "lrf/autoencoder/image_tensor.h"
#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/core/log.h"
#include "lrf/core/progress.h"
#include "lrf/core/safetensors.h"
#include "lrf/latent/latent_field.h"
#include "lrf/scene/scene_outputs.h"

namespace fs = std::filesystem;

namespace lrf {

std::vector<int> split_views(const Scene& scene, const std::string& split, const std::string& run) {
  std::vector<int> indices;
  if (split == "test") {
    indices = scene.test_indices;
  } else if (split == "train") {
    indices = scene.train_indices;
  } else if (split == "all") {
    for (size_t i = 0; i < scene.views.size(); ++i) indices.push_back(static_cast<int>(i));
  } else {
    fail_usage("--split must be test, train or all");
  }
  if (indices.empty()) fail(run, "the '" + split + "' split has no views");
  return indices;
}

std::string renders_folder(const std::string& run, const ViewRenders& request, const Scene& scene) {
  const std::string dir = request.dir.empty() ? (fs::path(run) / "renders" / request.split).string() : request.dir;
  refuse_output_in_scene(dir, scene);
  fs::create_directories(dir);
  return dir;
}

int write_decoded_views(const std::string& run, const ViewRenders& request, const Scene& scene,
                        const LatentRange& range, const std::function<std::unique_ptr<Autoencoder>()>& load_autoencoder,
                        const std::function<torch::Tensor(int)>& render_view) {
  const std::vector<int> views = split_views(scene, request.split, run);
  if (request.scale != 1.0 || request.width > 0)
    fail_usage("--scale/--width/--height apply to RGB fields; latent fields render at their latent resolution and "
               "decode at 8x");
  const std::string dir = renders_folder(run, request, scene);
  const std::unique_ptr<Autoencoder> ae = load_autoencoder();
  Progress progress("render", static_cast<long>(views.size()));
  long done = 0;
  for (int i : views) {
    const auto& view = scene.views[static_cast<size_t>(i)];
    auto zn = render_view(i);
    const std::string stem = (fs::path(dir) / fs::path(view.name).stem()).string();
    StateDict latent;
    latent.insert("latent", range.denormalize(zn).contiguous());
    write_safetensors(stem + ".safetensors", latent, {{"view", view.name}, {"space", "raw latent"}});
    write_image_rgb(stem + ".png", tensor_to_image(decode_normalised(*ae, range, zn)));
    progress.update(++done);
  }
  progress.finish();
  log_info("wrote " + std::to_string(views.size()) + " latents (.safetensors) and decoded images to " + dir);
  return static_cast<int>(views.size());
}

LatentEvalOptions decoded_eval_options(const FieldScoring& scoring) {
  if (scoring.scale != 1.0) fail_usage("--scale applies to RGB fields; latent fields are scored at 8x their latent size");
  LatentEvalOptions e;
  e.decoder = scoring.decoder;
  e.lpips_weights = scoring.lpips_weights;
  return e;
}

}  // namespace lrf
