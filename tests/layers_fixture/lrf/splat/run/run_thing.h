#pragma once
// A run folder's header reaching up to a field kind: the include the floors forbid.
#include "lrf/core/core_thing.h"
#include "lrf/latent/latent_thing.h"
