#pragma once
// The FieldType of RGB Gaussian fields; callers reach it through field_type() and field_type_of() (field_type.h).
#include "lrf/field_kinds/field_type.h"

namespace lrf {

const FieldType& rgb_field_type();

}  // namespace lrf
