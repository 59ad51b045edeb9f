// Built with -mavx2 (CMakeLists.txt) and without the precompiled header, whose flags differ. Nothing here
// may run before raster_dispatch.cpp has checked that the CPU has AVX2.
#include "lrf/splat/raster_tiles.h"
#include "lrf/splat/raster_widths.h"

#if defined(__AVX2__)
namespace lrf::splat::widths {

void forward_avx2(const RasterInputs& in, const ColorSource& source, const RasterForwardOutputs& out) {
  tiles::forward_any<simd::Avx2>(in, source, out);
}

void backward_avx2(int64_t n, const RasterInputs& in, const RasterBackwardInputs& bin, const RasterGrads& out) {
  tiles::backward_any<simd::Avx2>(n, in, bin, out);
}

}  // namespace lrf::splat::widths
#endif
