#pragma once
// The FieldType of latent Gaussian fields (feature and refined fields included); callers reach it through field_type() and field_type_of() (field_type.h).
#include "lrf/field_kinds/field_type.h"

namespace lrf {

const FieldType& latent_field_type();

}  // namespace lrf
