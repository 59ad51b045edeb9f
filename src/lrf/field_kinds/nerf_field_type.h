#pragma once
// The FieldType of latent NeRFs; callers reach it through field_type() and field_type_of() (field_type.h).
#include "lrf/field_kinds/field_type.h"

namespace lrf {

const FieldType& nerf_field_type();

}  // namespace lrf
