#pragma once
// 16×16 tile binning: every visible Gaussian is listed in each tile of its rectangle, each tile's list
// sorted front to back by camera-space depth (ties by index, so the order is deterministic).
#include <cstdint>
#include <vector>

namespace lrf::splat {

struct TileBins {
  std::vector<int32_t> offsets;  // [tiles + 1]: tile t's list is ids[offsets[t], offsets[t + 1])
  std::vector<int32_t> ids;      // Gaussian indices
};

// rect: [N,4] tiles [x0, x1) × [y0, y1) per Gaussian (empty = not binned); depth: [N] (> 0 where binned).
TileBins bin_gaussians(int64_t n, const float* depth, const int32_t* rect, int tiles_x, int tiles_y);

}  // namespace lrf::splat
