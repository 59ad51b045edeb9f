#pragma once
// The kind of a trained field, told once from its folder: every command that opens a run (train --resume,
// eval, render, serve, refine, the fine-tunings, compare and pipeline) asks here instead of reading
// config.json's "space" string itself.
//   rgb          Gaussians with RGB (SH) colours (lrf train --space rgb; compare's rgb/* rows)
//   latent       Gaussians with latent (or feature, lifted to latent) vectors, decoded by an autoencoder;
//                a refined latent field is one too
//   latent_nerf  the latent NeRF baseline (a hash grid and MLPs), decoded like a latent field
#include <optional>
#include <string>

#include <nlohmann/json_fwd.hpp>

namespace lrf {

enum class FieldKind { rgb, latent, latent_nerf };

// "rgb", "latent", "latent-nerf": the value of config.json's "space" and of `lrf train --space`.
std::string field_kind_name(FieldKind kind);

// The kind named `space`, or nullopt for an unknown name.
std::optional<FieldKind> field_kind_named(const std::string& space);
// Parses a "space" value; throws lrf::Error naming `where` (a file or an option) and the choices otherwise.
FieldKind parse_field_kind(const std::string& space, const std::string& where);

// The kind recorded in a run's parsed config.json (read from `path`). RGB fields written before "space"
// was recorded have none and are rgb. Throws lrf::Error naming `path` on a non-object or a bad "space".
FieldKind field_kind_of_config(const nlohmann::json& config, const std::string& path);

// The kind of the field in a folder: field_kind_of_folder.h.

}  // namespace lrf
