#pragma once
// A header on the field kinds' floor.
#include "lrf/core/core_thing.h"
