#include "lrf/latent/trained_run_checks.h"

#include "lrf/core/error.h"
#include "lrf/latent/latent_cache.h"

namespace lrf {

void check_autoencoder_unchanged(const std::string& autoencoder, const std::string& encoder,
                                 const std::string& recorded_identity, const std::string& config_path) {
  const std::string now = autoencoder_identity(autoencoder, encoder);
  if (now != recorded_identity)
    fail(config_path, "the autoencoder's files changed since training (was " + recorded_identity + ", now " + now +
                          "): retrain, or restore the weights");
}

Scene reload_trained_scene(const std::string& root, const SceneOptions& options, const std::vector<int>& resolution,
                           const std::string& config_path) {
  Scene scene = load_scene(root, options);
  if (scene.views.empty()) fail(config_path, "the scene has no views");
  const Camera& c0 = scene.views[0].camera;
  const bool recorded = !resolution.empty();
  if (recorded && (resolution.size() != 2 || resolution[0] != c0.width || resolution[1] != c0.height))
    fail(config_path, "the scene's images changed resolution since training");
  return scene;
}

}  // namespace lrf
