#include "lrf/splat/run/field_kind.h"

#include <nlohmann/json.hpp>

#include "lrf/core/error.h"

namespace lrf {

std::string field_kind_name(FieldKind kind) {
  switch (kind) {
    case FieldKind::rgb: return "rgb";
    case FieldKind::latent: return "latent";
    case FieldKind::latent_nerf: return "latent-nerf";
  }
  return "?";
}

std::optional<FieldKind> field_kind_named(const std::string& space) {
  for (FieldKind k : {FieldKind::rgb, FieldKind::latent, FieldKind::latent_nerf})
    if (space == field_kind_name(k)) return k;
  return std::nullopt;
}

FieldKind parse_field_kind(const std::string& space, const std::string& where) {
  if (const auto kind = field_kind_named(space)) return *kind;
  fail(where, "unknown space '" + space + "' (rgb, latent or latent-nerf)");
}

FieldKind field_kind_of_config(const nlohmann::json& c, const std::string& path) {
  if (!c.is_object()) fail(path, "not a JSON object: is it the config.json of 'lrf train'?");
  if (!c.contains("space")) return FieldKind::rgb;
  if (!c["space"].is_string()) fail(path, "\"space\" is not a string");
  return parse_field_kind(c["space"].get<std::string>(), path);
}

}  // namespace lrf
