#include "lrf/latent/latent_config.h"

#include "lrf/core/error.h"
#include "lrf/feature/feature_lift.h"
#include "lrf/splat/run/field_kind.h"

namespace lrf {

LatentConfig parse_latent_config(const nlohmann::json& c, const std::string& path) {
  LatentConfig l;
  // An RGB run is told as such before the settings a latent field would have are looked for; a latent
  // NeRF is refused by parse_field_config as not a Gaussian field.
  const FieldKind kind = field_kind_of_config(c, path);
  if (kind == FieldKind::rgb) {
    fail(path, "holds a field of space '" + field_kind_name(kind) +
                   "', not a latent field (make one with `lrf train --space latent`)");
  }
  l.field = splat::parse_field_config(c, path);
  try {
    l.autoencoder = c.at("autoencoder").get<std::string>();
    l.encoder = c.value("encoder", std::string());
    l.identity = c.at("autoencoder_identity").get<std::string>();
    l.decoder = c.value("decoder", std::string());
    l.decoder_identity = c.value("decoder_identity", std::string());
    l.range = LatentRange::from_json(c.at("latent_range"), path);
    if (c.contains("resolution")) {
      const auto& r = c["resolution"];
      if (!r.is_array() || r.size() != 2 || !r[0].is_number_integer() || !r[1].is_number_integer() ||
          r[0].get<int64_t>() < 1 || r[1].get<int64_t>() < 1 || r[0].get<int64_t>() > (1 << 16) ||
          r[1].get<int64_t>() > (1 << 16)) {
        fail(path, "\"resolution\" must be [width, height] with 1 to 65536 pixels per side");
      }
      l.resolution = {r[0].get<int>(), r[1].get<int>()};
    }
    if (c.contains("feature_dim")) {
      const auto& d = c["feature_dim"];
      if (!d.is_number_integer() || d.get<int64_t>() < 1 || d.get<int64_t>() > kMaxFeatureDim)
        fail(path, "\"feature_dim\" must be an integer from 1 to " + std::to_string(kMaxFeatureDim));
      l.feature_dim = d.get<int>();
    }
  } catch (const nlohmann::json::exception& e) {
    fail(path, std::string("missing or bad latent field settings: ") + e.what());
  }
  if (l.feature_dim > 0) {
    if (static_cast<int>(l.field.background.size()) != l.feature_dim) {
      fail(path, "\"background\" has " + std::to_string(l.field.background.size()) + " channels, \"feature_dim\" " +
                     std::to_string(l.feature_dim));
    }
  } else if (static_cast<int>(l.field.background.size()) != l.range.channels()) {
    fail(path, "\"background\" has " + std::to_string(l.field.background.size()) + " channels, \"latent_range\" " +
                   std::to_string(l.range.channels()));
  }
  return l;
}

}  // namespace lrf
