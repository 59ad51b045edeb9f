#pragma once
// The compositing kernels of raster_tiles.h compiled at each vector width (one source file per width, so
// that only the AVX2 one is built with -mavx2). raster_dispatch.cpp picks one at run time.
#include <cstdint>

#include "lrf/splat/raster/projection.h"
#include "lrf/splat/raster/raster_kernels.h"

namespace lrf::splat::widths {

// 4 lanes (SSE2) on x86-64, 1 lane elsewhere.
void forward_baseline(const RasterInputs& in, const ColorSource& source, const RasterForwardOutputs& out);
void backward_baseline(int64_t n, const RasterInputs& in, const RasterBackwardInputs& bin, const RasterGrads& out);
void project_baseline(int64_t n, const float* means, const float* log_scales, const float* quats,
                      const float* opacity_logits, const Viewpoint& view, const Projected& out);
void project_backward_baseline(int64_t n, const float* means, const float* log_scales, const float* quats,
                               const float* opacity_logits, const int32_t* radii, const Viewpoint& view,
                               const ProjectedGrads& g, float* d_means, float* d_log_scales, float* d_quats,
                               float* d_opacity_logits);
int baseline_width();

// 1 lane, portable C++: what non-x86 builds run, kept selectable everywhere so that tests cover it.
void forward_scalar(const RasterInputs& in, const ColorSource& source, const RasterForwardOutputs& out);
void backward_scalar(int64_t n, const RasterInputs& in, const RasterBackwardInputs& bin, const RasterGrads& out);
void project_scalar(int64_t n, const float* means, const float* log_scales, const float* quats,
                    const float* opacity_logits, const Viewpoint& view, const Projected& out);
void project_backward_scalar(int64_t n, const float* means, const float* log_scales, const float* quats,
                             const float* opacity_logits, const int32_t* radii, const Viewpoint& view,
                             const ProjectedGrads& g, float* d_means, float* d_log_scales, float* d_quats,
                             float* d_opacity_logits);

// 8 lanes; exists when the build has the AVX2 file (LRF_AVX2_KERNELS), to be called only on CPUs with AVX2.
void forward_avx2(const RasterInputs& in, const ColorSource& source, const RasterForwardOutputs& out);
void backward_avx2(int64_t n, const RasterInputs& in, const RasterBackwardInputs& bin, const RasterGrads& out);
void project_avx2(int64_t n, const float* means, const float* log_scales, const float* quats,
                  const float* opacity_logits, const Viewpoint& view, const Projected& out);
void project_backward_avx2(int64_t n, const float* means, const float* log_scales, const float* quats,
                           const float* opacity_logits, const int32_t* radii, const Viewpoint& view,
                           const ProjectedGrads& g, float* d_means, float* d_log_scales, float* d_quats,
                           float* d_opacity_logits);

}  // namespace lrf::splat::widths
