#pragma once
// Reopening any latent run (a Gaussian field, a NeRF) for rendering or scoring: the checks that the
// autoencoder and the scene are still the ones it was trained with, each failing with the config's path.
#include <string>
#include <vector>

#include "lrf/scene/scene.h"

namespace lrf {

// A latent field only makes sense in the latent space it was fitted in: fails when the autoencoder's
// files (and fine-tuned encoder) no longer match the identity recorded at training.
void check_autoencoder_unchanged(const std::string& autoencoder, const std::string& encoder,
                                 const std::string& recorded_identity, const std::string& config_path);

// The scene as the run was trained on it; fails when it has no views or when its images no longer have
// the recorded resolution {width, height} (an empty record is not checked, as in older runs).
Scene reload_trained_scene(const std::string& root, const SceneOptions& options, const std::vector<int>& resolution,
                           const std::string& config_path);

}  // namespace lrf
