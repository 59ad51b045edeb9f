#include "lrf/latent/encoded_scene.h"

#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/resources.h"
#include "lrf/latent/latent_cache.h"

namespace lrf {

void require_latent_scene_options(const SceneOptions& options, const std::string& space) {
  if (!options.test_list.empty() || !options.format.empty())
    fail_usage("--test-list and --format are not available with --space " + space + " yet");
}

EncodedScene load_encoded_scene(const EncodedSceneRequest& r) {
  EncodedScene out;
  out.options = r.options;
  out.options.crop_to_multiple_of_8 = true;
  out.scene = load_scene(r.scene, out.options);
  if (out.scene.train_indices.empty()) fail(r.scene, "no training views");
  out.autoencoder = load_autoencoder(r.autoencoder, r.encoder);
  out.autoencoder_identity = autoencoder_identity(r.autoencoder, r.encoder);
  const Camera& c0 = out.scene.views[0].camera;
  log_info("scene " + r.scene + ": " + std::to_string(out.scene.train_indices.size()) + " training views at " +
           std::to_string(c0.width) + "x" + std::to_string(c0.height) + " -> latents " +
           std::to_string(out.autoencoder->latent_channels()) + "x" + std::to_string(c0.height / 8) + "x" +
           std::to_string(c0.width / 8) + " (" + out.autoencoder->description() + ")");
  Stopwatch encode_clock;
  auto cached = encode_views_cached(out.scene, out.scene.train_indices, *out.autoencoder, out.autoencoder_identity,
                                    r.cache_dir.empty() ? default_cache_dir() : r.cache_dir);
  out.encode_seconds = encode_clock.seconds();
  out.latents = std::move(cached.latents);
  log_info(std::string("training latents ") + (cached.hit ? "read from " : "encoded, cached in ") + cached.path);
  return out;
}

}  // namespace lrf
