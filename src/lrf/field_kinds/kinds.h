#pragma once
// The implementations of FieldType, one per kind; callers reach them through field_type() and
// field_type_of() (field_type.h), never by name.
#include "lrf/field_kinds/field_type.h"

namespace lrf {

const FieldType& rgb_field_type();
const FieldType& latent_field_type();
const FieldType& nerf_field_type();

}  // namespace lrf
