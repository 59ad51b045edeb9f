// Built with -mavx2 (CMakeLists.txt) and without the precompiled header, whose flags differ. Nothing here
// may run before raster_dispatch.cpp has checked that the CPU has AVX2.
#include "lrf/splat/raster/projection_backward_lanes.h"
#include "lrf/splat/raster/projection_lanes.h"
#include "lrf/splat/raster/raster_tiles.h"
#include "lrf/splat/raster/raster_widths.h"

#if defined(__AVX2__)
namespace lrf::splat::widths {

void forward_avx2(const RasterInputs& in, const ColorSource& source, const RasterForwardOutputs& out) {
  tiles::forward_any<simd::Avx2>(in, source, out);
}

void backward_avx2(int64_t n, const RasterInputs& in, const RasterBackwardInputs& bin, const RasterGrads& out) {
  tiles::backward_any<simd::Avx2>(n, in, bin, out);
}

void project_avx2(int64_t n, const float* means, const float* log_scales, const float* quats,
                  const float* opacity_logits, const Viewpoint& view, const Projected& out) {
  lanes::project_forward<simd::Avx2>(n, means, log_scales, quats, opacity_logits, view, out);
}

void project_backward_avx2(int64_t n, const float* means, const float* log_scales, const float* quats,
                           const float* opacity_logits, const int32_t* radii, const Viewpoint& view,
                           const ProjectedGrads& g, float* d_means, float* d_log_scales, float* d_quats,
                           float* d_opacity_logits) {
  lanes::project_backward<simd::Avx2>(n, means, log_scales, quats, opacity_logits, radii, view, g, d_means, d_log_scales,
                                      d_quats, d_opacity_logits);
}

}  // namespace lrf::splat::widths
#endif
