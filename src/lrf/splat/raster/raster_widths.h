#pragma once
// The compositing and projection kernels compiled at each vector width (one source file per width, so
// that only the AVX2 one is built with -mavx2). raster_dispatch.cpp picks one set at run time.
#include <cstdint>

#include "lrf/splat/raster/projection.h"
#include "lrf/splat/raster/raster_kernels.h"

namespace lrf::splat::widths {

// Every kernel of one width.
struct KernelSet {
  int width;
  void (*forward)(const RasterInputs&, const ColorSource&, const RasterForwardOutputs&);
  void (*backward)(int64_t, const RasterInputs&, const RasterBackwardInputs&, const RasterGrads&);
  void (*project)(int64_t, const float*, const float*, const float*, const float*, const Viewpoint&,
                  const Projected&);
  void (*project_backward)(int64_t, const float*, const float*, const float*, const float*, const int32_t*,
                           const Viewpoint&, const ProjectedGrads&, float*, float*, float*, float*);
};

// 4 lanes (SSE2) on x86-64, 1 lane elsewhere.
KernelSet baseline_kernels();
// 1 lane, portable C++: what non-x86 builds run, kept selectable everywhere so that tests cover it.
KernelSet scalar_kernels();
// 8 lanes; exists when the build has the AVX2 file (LRF_AVX2_KERNELS). Its code is compiled with -mavx2, so
// even this call may use AVX2 instructions: call it only on CPUs with AVX2.
KernelSet avx2_kernels();

}  // namespace lrf::splat::widths
