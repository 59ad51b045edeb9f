#pragma once
// The kernel templates instantiated for one vector interface of simd.h; included only by the per-width
// source files (raster_width_*.cpp), each compiled with its own instruction-set flags.
#include "lrf/splat/raster/projection_backward_lanes.h"
#include "lrf/splat/raster/projection_lanes.h"
#include "lrf/splat/raster/raster_tiles.h"
#include "lrf/splat/raster/raster_widths.h"

namespace lrf::splat::widths {

template <class V>
KernelSet kernel_set() {
  return {V::kWidth, &tiles::forward_any<V>, &tiles::backward_any<V>, &lanes::project_forward<V>,
          &lanes::project_backward<V>};
}

}  // namespace lrf::splat::widths
