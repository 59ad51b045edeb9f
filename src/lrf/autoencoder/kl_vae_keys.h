#pragma once
// Key-name mapping for the KL-f8 VAE: diffusers' AutoencoderKL names -> ldm names (the native ones),
// in one place. Also strips the "first_stage_model." (full SD checkpoints) and "vae." prefixes.
#include "lrf/core/state_dict.h"

namespace lrf {

// `num_up_levels` is needed because diffusers numbers decoder levels from the top (up_blocks.0 is
// the first applied = ldm's up.<n-1>); it is inferred from the keys when <= 0.
StateDict kl_keys_to_ldm(const StateDict& file, int num_up_levels = 0);

}  // namespace lrf
