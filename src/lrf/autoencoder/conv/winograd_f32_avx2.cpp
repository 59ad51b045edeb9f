// The float32 Winograd kernels for AVX2 with FMA: 8-lane vectors (compiled with -mavx2 -mfma).
#define LRF_LANES 8
#define LRF_ISA_NAMESPACE avx2
#include "lrf/autoencoder/conv/winograd_f32_kernels.inc"

namespace lrf::winograd_f32 {

const Kernels& avx2_kernels() {
  static const Kernels kernels{8, &avx2::forward, &avx2::weight_gradient};
  return kernels;
}

}  // namespace lrf::winograd_f32
