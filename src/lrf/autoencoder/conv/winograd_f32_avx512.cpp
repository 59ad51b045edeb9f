// The float32 Winograd kernels for AVX-512F: 16-lane vectors (compiled with -mavx512f -mfma).
#define LRF_LANES 16
#define LRF_ISA_NAMESPACE avx512
#include "lrf/autoencoder/conv/winograd_f32_kernels.inc"

namespace lrf::winograd_f32 {

const Kernels& avx512_kernels() {
  static const Kernels kernels{16, &avx512::forward, &avx512::weight_gradient};
  return kernels;
}

}  // namespace lrf::winograd_f32
