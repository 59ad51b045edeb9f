#include <atomic>

#include "lrf/splat/raster_kernels.h"
#include "lrf/splat/raster_widths.h"

namespace lrf::splat {
namespace {

bool cpu_has_avx2() {
#if defined(LRF_AVX2_KERNELS)
  return __builtin_cpu_supports("avx2");
#else
  return false;
#endif
}

int widest_width() { return cpu_has_avx2() ? 8 : widths::baseline_width(); }

std::atomic<int>& chosen_width() {
  static std::atomic<int> width{widest_width()};
  return width;
}

}  // namespace

int raster_vector_width() { return chosen_width().load(); }

bool set_raster_vector_width(int width) {
  const bool supported = width == 1 || width == widths::baseline_width() || (width == 8 && cpu_has_avx2());
  if (supported) chosen_width().store(width);
  return supported;
}

void rasterize_forward(const RasterInputs& in, const ColorSource& source, const RasterForwardOutputs& out) {
#if defined(LRF_AVX2_KERNELS)
  if (raster_vector_width() == 8) return widths::forward_avx2(in, source, out);
#endif
  if (raster_vector_width() == 1) return widths::forward_scalar(in, source, out);
  widths::forward_baseline(in, source, out);
}

void rasterize_backward(int64_t n, const RasterInputs& in, const RasterBackwardInputs& bin, const RasterGrads& out) {
#if defined(LRF_AVX2_KERNELS)
  if (raster_vector_width() == 8) return widths::backward_avx2(n, in, bin, out);
#endif
  if (raster_vector_width() == 1) return widths::backward_scalar(n, in, bin, out);
  widths::backward_baseline(n, in, bin, out);
}

}  // namespace lrf::splat
