#include <atomic>

#include "lrf/core/cpu_features.h"
#include "lrf/splat/raster/projection.h"
#include "lrf/splat/raster/raster_kernels.h"
#include "lrf/splat/raster/raster_widths.h"

namespace lrf::splat {
namespace {

struct Kernels {
  int width;
  void (*forward)(const RasterInputs&, const ColorSource&, const RasterForwardOutputs&);
  void (*backward)(int64_t, const RasterInputs&, const RasterBackwardInputs&, const RasterGrads&);
  void (*project)(int64_t, const float*, const float*, const float*, const float*, const Viewpoint&,
                  const Projected&);
  void (*project_backward)(int64_t, const float*, const float*, const float*, const float*, const int32_t*,
                           const Viewpoint&, const ProjectedGrads&, float*, float*, float*, float*);
};

const Kernels kScalar{1, widths::forward_scalar, widths::backward_scalar, widths::project_scalar,
                       widths::project_backward_scalar};
const Kernels kBaseline{widths::baseline_width(), widths::forward_baseline, widths::backward_baseline,
                         widths::project_baseline, widths::project_backward_baseline};
#if defined(LRF_AVX2_KERNELS)
const Kernels kAvx2{8, widths::forward_avx2, widths::backward_avx2, widths::project_avx2,
                     widths::project_backward_avx2};
#endif

// The kernels of that width, if this build has them and this CPU can run them.
const Kernels* kernels_of_width(int width) {
#if defined(LRF_AVX2_KERNELS)
  if (width == 8) return cpu_has_avx2() ? &kAvx2 : nullptr;
#endif
  if (width == kBaseline.width) return &kBaseline;
  if (width == 1) return &kScalar;
  return nullptr;
}

std::atomic<const Kernels*>& chosen() {
  static std::atomic<const Kernels*> kernels{kernels_of_width(8) ? kernels_of_width(8) : &kBaseline};
  return kernels;
}

}  // namespace

int raster_vector_width() { return chosen().load()->width; }

bool set_raster_vector_width(int width) {
  const Kernels* k = kernels_of_width(width);
  if (k) chosen().store(k);
  return k != nullptr;
}

void rasterize_forward(const RasterInputs& in, const ColorSource& source, const RasterForwardOutputs& out) {
  chosen().load()->forward(in, source, out);
}

void rasterize_backward(int64_t n, const RasterInputs& in, const RasterBackwardInputs& bin, const RasterGrads& out) {
  chosen().load()->backward(n, in, bin, out);
}

void project_forward(int64_t n, const float* means, const float* log_scales, const float* quats,
                     const float* opacity_logits, const Viewpoint& view, const Projected& out) {
  chosen().load()->project(n, means, log_scales, quats, opacity_logits, view, out);
}

void project_backward(int64_t n, const float* means, const float* log_scales, const float* quats,
                      const float* opacity_logits, const int32_t* radii, const Viewpoint& view,
                      const ProjectedGrads& g, float* d_means, float* d_log_scales, float* d_quats,
                      float* d_opacity_logits) {
  chosen().load()->project_backward(n, means, log_scales, quats, opacity_logits, radii, view, g, d_means,
                                    d_log_scales, d_quats, d_opacity_logits);
}

}  // namespace lrf::splat
