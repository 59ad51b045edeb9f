#include "lrf/splat/raster/raster_kernel_set.h"

namespace lrf::splat::widths {

#if defined(__SSE2__)
KernelSet baseline_kernels() { return kernel_set<simd::Sse2>(); }
#else
KernelSet baseline_kernels() { return kernel_set<simd::Scalar>(); }
#endif

KernelSet scalar_kernels() { return kernel_set<simd::Scalar>(); }

}  // namespace lrf::splat::widths
