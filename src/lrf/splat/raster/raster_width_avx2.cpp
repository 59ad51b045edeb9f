// Built with -mavx2 (CMakeLists.txt) and without the precompiled header, whose flags differ. Nothing here
// may run before raster_dispatch.cpp has checked that the CPU has AVX2.
#include "lrf/splat/raster/raster_kernel_set.h"

#if defined(__AVX2__)
namespace lrf::splat::widths {

KernelSet avx2_kernels() { return kernel_set<simd::Avx2>(); }

}  // namespace lrf::splat::widths
#endif
