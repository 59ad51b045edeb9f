#include <atomic>

#include "lrf/core/cpu_features.h"
#include "lrf/core/run_info.h"
#include "lrf/splat/raster/projection.h"
#include "lrf/splat/raster/raster_kernels.h"
#include "lrf/splat/raster/raster_widths.h"

namespace lrf::splat {
namespace {

using widths::KernelSet;

const KernelSet& baseline() {
  static const KernelSet kernels = widths::baseline_kernels();
  return kernels;
}

// The kernels of that width, if this build has them and this CPU can run them.
const KernelSet* kernels_of_width(int width) {
#if defined(LRF_AVX2_KERNELS)
  if (width == 8) {
    if (!cpu_has_avx2()) return nullptr;
    static const KernelSet avx2 = widths::avx2_kernels();
    return &avx2;
  }
#endif
  static const KernelSet scalar = widths::scalar_kernels();
  if (width == baseline().width) return &baseline();
  if (width == 1) return &scalar;
  return nullptr;
}

std::atomic<const KernelSet*>& chosen() {
  static std::atomic<const KernelSet*> kernels{kernels_of_width(8) ? kernels_of_width(8) : &baseline()};
  return kernels;
}

}  // namespace

int raster_vector_width() { return chosen().load()->width; }

namespace {
// Pixels composited at a time (8 with AVX2, 4 with SSE2), in every run's versions: images do not depend on
// it, but gradients round differently, so a run reproduces exactly only at the same width.
const bool kWidthRecorded =
    (add_version_fact("compositing_lanes", [] { return nlohmann::json(raster_vector_width()); }), true);
}  // namespace

bool set_raster_vector_width(int width) {
  const KernelSet* k = kernels_of_width(width);
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
