#include "lrf/splat/raster/projection_backward_lanes.h"
#include "lrf/splat/raster/projection_lanes.h"
#include "lrf/splat/raster/raster_tiles.h"
#include "lrf/splat/raster/raster_widths.h"

namespace lrf::splat::widths {

#if defined(__SSE2__)
using Baseline = simd::Sse2;
#else
using Baseline = simd::Scalar;
#endif

void forward_baseline(const RasterInputs& in, const ColorSource& source, const RasterForwardOutputs& out) {
  tiles::forward_any<Baseline>(in, source, out);
}

void backward_baseline(int64_t n, const RasterInputs& in, const RasterBackwardInputs& bin, const RasterGrads& out) {
  tiles::backward_any<Baseline>(n, in, bin, out);
}

void project_baseline(int64_t n, const float* means, const float* log_scales, const float* quats,
                      const float* opacity_logits, const Viewpoint& view, const Projected& out) {
  lanes::project_forward<Baseline>(n, means, log_scales, quats, opacity_logits, view, out);
}

void project_backward_baseline(int64_t n, const float* means, const float* log_scales, const float* quats,
                               const float* opacity_logits, const int32_t* radii, const Viewpoint& view,
                               const ProjectedGrads& g, float* d_means, float* d_log_scales, float* d_quats,
                               float* d_opacity_logits) {
  lanes::project_backward<Baseline>(n, means, log_scales, quats, opacity_logits, radii, view, g, d_means, d_log_scales,
                                    d_quats, d_opacity_logits);
}

int baseline_width() { return Baseline::kWidth; }

void forward_scalar(const RasterInputs& in, const ColorSource& source, const RasterForwardOutputs& out) {
  tiles::forward_any<simd::Scalar>(in, source, out);
}

void backward_scalar(int64_t n, const RasterInputs& in, const RasterBackwardInputs& bin, const RasterGrads& out) {
  tiles::backward_any<simd::Scalar>(n, in, bin, out);
}

void project_scalar(int64_t n, const float* means, const float* log_scales, const float* quats,
                    const float* opacity_logits, const Viewpoint& view, const Projected& out) {
  lanes::project_forward<simd::Scalar>(n, means, log_scales, quats, opacity_logits, view, out);
}

void project_backward_scalar(int64_t n, const float* means, const float* log_scales, const float* quats,
                             const float* opacity_logits, const int32_t* radii, const Viewpoint& view,
                             const ProjectedGrads& g, float* d_means, float* d_log_scales, float* d_quats,
                             float* d_opacity_logits) {
  lanes::project_backward<simd::Scalar>(n, means, log_scales, quats, opacity_logits, radii, view, g, d_means, d_log_scales,
                                        d_quats, d_opacity_logits);
}

}  // namespace lrf::splat::widths
