#pragma once
// Gaussian fields as .ply files in the layout of the Inria 3DGS code, generalised to C channels:
// binary little-endian float32 vertex properties
//   x y z nx ny nz f_dc_0..f_dc_{C-1} f_rest_0..f_rest_{(K-1)C-1} opacity scale_0..2 rot_0..3
// where f_rest is channel-major (all higher-band coefficients of channel 0, then channel 1, ...), and
// scale / opacity are stored as log-scales and logits. With C = 3 the file opens in common splat viewers.
#include <string>

#include "lrf/splat/gaussians.h"

namespace lrf::splat {

void write_ply(const std::string& path, const Gaussians& g);
// Reads a field written by write_ply (or by the Inria code). `channels` > 0 demands that many
// channels. Throws lrf::Error naming the file on a bad header, missing or unexpected properties, or a
// size that disagrees with the file length.
Gaussians read_ply(const std::string& path, int channels = 0);
// Same, from the file's bytes already in memory (`name` is used in error messages).
Gaussians parse_ply(const std::string& bytes, const std::string& name, int channels = 0);

}  // namespace lrf::splat
