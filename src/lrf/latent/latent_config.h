#pragma once
// The settings of a latent field's config.json (Stage II) that reopening it needs, parsed and checked
// without touching the file system (see splat/run/run_config.h).
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lrf/latent/latent_normalization.h"
#include "lrf/splat/run/run_config.h"

namespace lrf {

struct LatentConfig {
  splat::FieldConfig field;  // space "latent"; background has one value per rendered channel
  std::string autoencoder, encoder, identity;
  // A field refined through a decoder (lrf refine) is decoded by that decoder unless told otherwise:
  // its weights file ("" = the autoencoder's own decoder) and that file's identity when it was used.
  std::string decoder, decoder_identity;
  LatentRange range;
  std::vector<int> resolution;  // training resolution (width, height) when recorded, else empty
  // A feature field's feature count ("feature_dim"; its background has that many values), 0 for a latent
  // field.
  int feature_dim = 0;
};

LatentConfig parse_latent_config(const nlohmann::json& config, const std::string& config_path);

}  // namespace lrf
