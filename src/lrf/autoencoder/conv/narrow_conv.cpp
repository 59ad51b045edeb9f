#include "lrf/autoencoder/conv/narrow_conv.h"

#include <algorithm>
#include <cstring>
#include <string>

#include <ATen/ATen.h>
#include <ATen/Parallel.h>

#include "lrf/autoencoder/conv/bf16_vectors.h"
#include "lrf/autoencoder/conv/conv_destination.h"
#include "lrf/core/cpu_features.h"
#include "lrf/core/error.h"

namespace lrf {
namespace {

constexpr int kPixels = 8;  // neighbouring output pixels in registers at once: 8 x O accumulators

std::string shape_of(const at::Tensor& t) { return c10::str(t.sizes()); }

#if defined(__x86_64__)
// The 16 lanes of a vector folded to 8. (GCC 12's _mm512_castps512_ps256 reads an uninitialised register
// and warns about it.)
LRF_AVX512_BF16 inline __m256 fold(__m512 v) {
  return _mm256_add_ps(_mm512_extractf32x8_ps(v, 0), _mm512_extractf32x8_ps(v, 1));
}

// The lane sums of 8 vectors, one per lane of the result.
LRF_AVX512_BF16 inline __m256 lane_sums(const __m512 (&v)[kPixels]) {
  const __m256 t0 = _mm256_hadd_ps(fold(v[0]), fold(v[1]));  // pairs of v0 and v1, per 128-bit half
  const __m256 t1 = _mm256_hadd_ps(fold(v[2]), fold(v[3]));
  const __m256 t2 = _mm256_hadd_ps(fold(v[4]), fold(v[5]));
  const __m256 t3 = _mm256_hadd_ps(fold(v[6]), fold(v[7]));
  const __m256 u0 = _mm256_hadd_ps(t0, t1);  // v0..v3's quarter sums, low half then high half
  const __m256 u1 = _mm256_hadd_ps(t2, t3);
  return _mm256_add_ps(_mm256_permute2f128_ps(u0, u1, 0x20), _mm256_permute2f128_ps(u0, u1, 0x31));
}

struct Row {
  const uint16_t* taps[3];  // input rows y - 1, y, y + 1, null outside the image
  int64_t width, inputs;
  const uint16_t* weights;  // [9][O][I]
  const float* bias;
  bool relu;
  uint16_t* out;  // the output row, [W][O]; holds the residual when `residual`
  bool residual;
};

// Output pixels x0 .. x0 + count - 1 of a row. `Edge`: some of their taps fall outside the row, or the
// group is short; otherwise every load is inside and unchecked.
template <int O, bool Edge>
LRF_AVX512_BF16 void pixels(const Row& r, int64_t x0, int count) {
  __m512 acc[O][kPixels];
  for (int o = 0; o < O; ++o)
    for (int p = 0; p < kPixels; ++p) acc[o][p] = _mm512_setzero_ps();
  for (int dy = 0; dy < 3; ++dy) {
    const uint16_t* row = r.taps[dy];
    if (!row) continue;
    for (int dx = 0; dx < 3; ++dx) {
      const uint16_t* w = r.weights + (dy * 3 + dx) * O * r.inputs;
      for (int64_t c = 0; c < r.inputs; c += 32) {
        __m512bh b[O];
        for (int o = 0; o < O; ++o) b[o] = reinterpret_cast<__m512bh>(_mm512_loadu_si512(w + o * r.inputs + c));
        for (int p = 0; p < kPixels; ++p) {
          const int64_t x = x0 + p + dx - 1;
          if (Edge && (p >= count || x < 0 || x >= r.width)) continue;
          const __m512bh a = reinterpret_cast<__m512bh>(_mm512_loadu_si512(row + x * r.inputs + c));
          for (int o = 0; o < O; ++o) acc[o][p] = _mm512_dpbf16_ps(acc[o][p], a, b[o]);
        }
      }
    }
  }
  for (int o = 0; o < O; ++o) {
    __m256 v = _mm256_add_ps(lane_sums(acc[o]), _mm256_set1_ps(r.bias[o]));
    uint16_t* out = r.out + x0 * O + o;
    if (r.residual) {
      alignas(32) float before[kPixels] = {};
      for (int p = 0; p < kPixels && p < count; ++p) {
        const uint32_t bits = static_cast<uint32_t>(out[p * O]) << 16;
        std::memcpy(&before[p], &bits, sizeof bits);
      }
      v = _mm256_add_ps(v, _mm256_load_ps(before));
    }
    if (r.relu) v = _mm256_max_ps(v, _mm256_setzero_ps());
    alignas(16) uint16_t rounded[kPixels];
    _mm_store_si128(reinterpret_cast<__m128i*>(rounded), reinterpret_cast<__m128i>(_mm256_cvtneps_pbh(v)));
    for (int p = 0; p < kPixels && p < count; ++p) out[p * O] = rounded[p];
  }
}

template <int O>
LRF_AVX512_BF16 void convolve_row(const Row& r) {
  for (int64_t x0 = 0; x0 < r.width; x0 += kPixels) {
    const int count = static_cast<int>(std::min<int64_t>(kPixels, r.width - x0));
    if (x0 >= 1 && x0 + kPixels < r.width) {
      pixels<O, false>(r, x0, kPixels);
    } else {
      pixels<O, true>(r, x0, count);
    }
  }
}
#endif

}  // namespace

bool NarrowConv3x3::takes(int64_t outputs, int64_t inputs) {
  return outputs >= 1 && outputs <= 3 && inputs > 0 && inputs % 32 == 0;
}

bool NarrowConv3x3::available() {
#if defined(__x86_64__)
  return cpu_has_avx512_bf16() && fused_conv_enabled();
#else
  return false;
#endif
}

NarrowConv3x3::NarrowConv3x3(const at::Tensor& weight, const at::Tensor& bias) {
  if (weight.dim() != 4 || weight.size(2) != 3 || weight.size(3) != 3) {
    fail("NarrowConv3x3: weight must be [O, I, 3, 3], got " + shape_of(weight));
  }
  outputs_ = weight.size(0), inputs_ = weight.size(1);
  if (!takes(outputs_, inputs_)) {
    fail("NarrowConv3x3: needs 1 to 3 outputs and a multiple of 32 inputs, got " + shape_of(weight));
  }
  // [O, I, 3, 3] -> [3, 3, O, I]: each tap's O weight vectors side by side, channels contiguous.
  const at::Tensor w = weight.detach().to(at::kFloat).permute({2, 3, 0, 1}).contiguous().to(at::kBFloat16);
  const auto* src = reinterpret_cast<const uint16_t*>(w.data_ptr());
  weights_.assign(src, src + w.numel());
  bias_ = conv_bias("NarrowConv3x3", bias, outputs_);
}

at::Tensor NarrowConv3x3::forward(const at::Tensor& input, bool relu, const at::Tensor& residual) const {
  if (input.dim() != 4 || input.size(1) != inputs_ || input.scalar_type() != at::kBFloat16) {
    fail("NarrowConv3x3: input must be bf16 [N, " + std::to_string(inputs_) + ", H, W], got " + shape_of(input));
  }
  if (!available()) fail("NarrowConv3x3: not available (the CPU has no AVX512_BF16, or LRF_FUSED_CONV=0)");
  const at::Tensor x = input.contiguous(at::MemoryFormat::ChannelsLast);
  const int64_t n = x.size(0), h = x.size(2), w = x.size(3);
  at::Tensor out = conv_destination("NarrowConv3x3", x, residual, {n, outputs_, h, w});
  if (x.numel() == 0) return out;
#if defined(__x86_64__)
  const auto* in = reinterpret_cast<const uint16_t*>(x.data_ptr());
  auto* dst = reinterpret_cast<uint16_t*>(out.data_ptr());
  const int64_t inputs = inputs_, outputs = outputs_;
  at::parallel_for(0, n * h, 4, [&](int64_t begin, int64_t end) {
    for (int64_t image_row = begin; image_row < end; ++image_row) {
      const int64_t image = image_row / h, y = image_row % h;
      Row r{{}, w, inputs, weights_.data(), bias_.data(), relu, dst + image_row * w * outputs, residual.defined()};
      for (int dy = 0; dy < 3; ++dy) {
        const int64_t yy = y + dy - 1;
        r.taps[dy] = yy >= 0 && yy < h ? in + (image * h + yy) * w * inputs : nullptr;
      }
      if (outputs == 1) {
        convolve_row<1>(r);
      } else if (outputs == 2) {
        convolve_row<2>(r);
      } else {
        convolve_row<3>(r);
      }
    }
  });
#endif
  return out;
}

}  // namespace lrf
