#include "lrf/field_kinds/field_type.h"

#include "lrf/field_kinds/latent_field_type.h"
#include "lrf/field_kinds/nerf_field_type.h"
#include "lrf/field_kinds/rgb_field_type.h"
#include "lrf/splat/run/field_kind_of_folder.h"

namespace lrf {

const FieldType& field_type(FieldKind kind) {
  switch (kind) {
    case FieldKind::latent:
      return latent_field_type();
    case FieldKind::latent_nerf:
      return nerf_field_type();
    case FieldKind::rgb:
      break;
  }
  return rgb_field_type();
}

const FieldType& field_type_of(const std::string& run) {
  // A folder without config.json is taken for an RGB run, whose opening names the missing file (and, for a
  // scene folder given in its place, says so).
  return field_type(field_kind_of(run).value_or(FieldKind::rgb));
}

std::unique_ptr<FieldFrames> open_field_frames(const std::string& run, const std::string& decoder) {
  return field_type_of(run).frames(run, decoder);
}

}  // namespace lrf
