#pragma once
// The --autoencoder option, bound the same way by every command that takes one: one help text naming
// the families a user can choose from.
#include <string>

#include <CLI/CLI.hpp>

namespace lrf::cli {

// `role` says what the autoencoder is for in this command ("of the latent fields", ...).
inline CLI::Option* add_autoencoder_option(CLI::App* cmd, std::string* value, const std::string& role) {
  return cmd
      ->add_option("--autoencoder,-a", *value,
                   "Autoencoder " + role +
                       ": taef2 (32 channels: the closest round trip), vaelight (4 channels, Stable Diffusion's "
                       "latent space: the paper's regime), another name looked up in $LRF_MODELS, ./models and "
                       "../shared/models, a folder with *encoder* and *decoder* weights, or one weights file "
                       "(e.g. a KL-f8 VAE)")
      ->capture_default_str();
}

}  // namespace lrf::cli
