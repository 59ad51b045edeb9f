#include "lrf/autoencoder/conv/winograd_conv.h"

#include <algorithm>
#include <cstring>
#include <string>

#include <ATen/ATen.h>
#include <ATen/Parallel.h>

#include "lrf/autoencoder/conv/bf16_vectors.h"
#include "lrf/autoencoder/conv/conv_destination.h"
#include "lrf/autoencoder/conv/winograd_tiles.h"
#include "lrf/core/cpu_features.h"
#include "lrf/core/error.h"

namespace lrf {
namespace {

// Rounds to the nearest bf16, ties to even (NaN stays NaN), as c10::BFloat16 does, in a form loops
// vectorise.
inline uint16_t to_bf16(float v) {
  uint32_t bits;
  std::memcpy(&bits, &v, sizeof bits);
  if (v != v) return 0x7FC0;
  return static_cast<uint16_t>((bits + 0x7FFF + ((bits >> 16) & 1)) >> 16);
}

constexpr int kTilesPerPass = 6;   // tiles whose 64 outputs are accumulated in registers: 6 x 4 zmm

#if defined(__x86_64__)
using winograd::Geometry;
using winograd::kTilesPerUnit;

// m[t][o..o+64) = Σ_k v[t][k] u[k][o..o+64) for `Rows` tiles, one position; u in pairs of k.
template <int Rows>
LRF_AVX512_BF16 void multiply(const uint16_t* v, int64_t inputs, const uint16_t* u, int64_t outputs, float* m) {
  for (int64_t o = 0; o < outputs; o += 64) {
    __m512 acc[Rows][4];
    for (int r = 0; r < Rows; ++r)
      for (int q = 0; q < 4; ++q) acc[r][q] = _mm512_setzero_ps();
    const uint16_t* w = u + 2 * o;
    for (int64_t k = 0; k < inputs; k += 2, w += 2 * outputs) {
      __m512bh b[4];
      for (int q = 0; q < 4; ++q) b[q] = reinterpret_cast<__m512bh>(_mm512_loadu_si512(w + 32 * q));
      for (int r = 0; r < Rows; ++r) {
        int32_t pair;
        std::memcpy(&pair, v + r * inputs + k, sizeof pair);
        const __m512bh a = reinterpret_cast<__m512bh>(_mm512_set1_epi32(pair));
        for (int q = 0; q < 4; ++q) acc[r][q] = _mm512_dpbf16_ps(acc[r][q], a, b[q]);
      }
    }
    for (int r = 0; r < Rows; ++r)
      for (int q = 0; q < 4; ++q) _mm512_storeu_ps(m + r * outputs + o + 16 * q, acc[r][q]);
  }
}

LRF_AVX512_BF16 void multiply_rows(int rows, const uint16_t* v, int64_t inputs, const uint16_t* u, int64_t outputs,
                                   float* m) {
  switch (rows) {
    case 1: return multiply<1>(v, inputs, u, outputs, m);
    case 2: return multiply<2>(v, inputs, u, outputs, m);
    case 3: return multiply<3>(v, inputs, u, outputs, m);
    case 4: return multiply<4>(v, inputs, u, outputs, m);
    case 5: return multiply<5>(v, inputs, u, outputs, m);
    default: return multiply<6>(v, inputs, u, outputs, m);
  }
}

LRF_AVX512_BF16 void run(const Geometry& g, const uint16_t* in, const uint16_t* kernels, const float* bias, bool relu,
                         const uint16_t* residual, uint16_t* out) {
  const int64_t units = g.n * g.tiles_y * g.units_per_row;
  at::parallel_for(0, units, 1, [&](int64_t begin, int64_t end) {
    std::vector<uint16_t> v(static_cast<size_t>(g.positions() * kTilesPerUnit * g.inputs));
    std::vector<float> m(static_cast<size_t>(g.positions() * kTilesPerUnit * g.outputs));
    const int64_t position_stride = g.inputs / 2 * g.outputs * 2;
    for (int64_t unit = begin; unit < end; ++unit) {
      const int64_t image = unit / (g.tiles_y * g.units_per_row);
      const int64_t ty = unit / g.units_per_row % g.tiles_y;
      const int64_t tx0 = unit % g.units_per_row * kTilesPerUnit;
      const int tiles = static_cast<int>(std::min<int64_t>(kTilesPerUnit, g.tiles_x - tx0));
      if (g.tile == 3) {
        winograd::transform_inputs3(g, in, image, ty, tx0, tiles, v.data());
      } else {
        winograd::transform_inputs2(g, in, image, ty, tx0, tiles, v.data());
      }
      for (int p = 0; p < g.positions(); ++p) {
        const uint16_t* vp = v.data() + p * kTilesPerUnit * g.inputs;
        float* mp = m.data() + p * kTilesPerUnit * g.outputs;
        for (int t = 0; t < tiles; t += kTilesPerPass) {
          multiply_rows(std::min(kTilesPerPass, tiles - t), vp + t * g.inputs, g.inputs, kernels + p * position_stride,
                        g.outputs, mp + t * g.outputs);
        }
      }
      if (g.tile == 3) {
        winograd::transform_outputs3(g, m.data(), bias, relu, residual, out, image, ty, tx0, tiles);
      } else {
        winograd::transform_outputs2(g, m.data(), bias, relu, residual, out, image, ty, tx0, tiles);
      }
    }
  });
}
#endif

std::string shape_of(const at::Tensor& t) { return c10::str(t.sizes()); }

}  // namespace

bool WinogradConv3x3::takes(int64_t outputs, int64_t inputs) {
  return outputs > 0 && inputs > 0 && outputs % 64 == 0 && inputs % 32 == 0;
}

bool WinogradConv3x3::available() {
#if defined(__x86_64__)
  return winograd_enabled();
#else
  return false;
#endif
}

WinogradConv3x3::Tiles WinogradConv3x3::chosen_tiles() { return winograd_tile() == 3 ? Tiles::f3x3 : Tiles::f2x2; }

WinogradConv3x3::WinogradConv3x3(const at::Tensor& weight, const at::Tensor& bias, bool upsampled_input, Tiles tiles)
    : upsampled_(upsampled_input), tile_(tiles == Tiles::f3x3 ? 3 : 2) {
  if (upsampled_ && tile_ != 2) fail("WinogradConv3x3: an upsampled input takes 2x2 tiles only");
  if (weight.dim() != 4 || weight.size(2) != 3 || weight.size(3) != 3) {
    fail("WinogradConv3x3: weight must be [O, I, 3, 3], got " + shape_of(weight));
  }
  outputs_ = weight.size(0), inputs_ = weight.size(1);
  if (!takes(outputs_, inputs_)) {
    fail("WinogradConv3x3: needs a multiple of 64 outputs and of 32 inputs, got " + shape_of(weight));
  }
  // U = G g Gᵀ in float64, rounded once to bf16 (through float32); upsampled, only rows and columns 0, 1,
  // 3, with the factor 2 of the input transform's row (column) 1. G is F(2x2)'s, or F(3x3)'s for the
  // points 0, 1, -1, ½, ∞ (input_transform3). The training passes transform their
  // weights on every call, so the loops run over the outputs (contiguous, vectorised) for each input,
  // inputs spread over the threads.
  const at::Tensor w = weight.detach().to(at::kDouble).permute({1, 2, 3, 0}).contiguous();  // [I, 3, 3, O]
  const double* src = w.data_ptr<double>();
  constexpr double G2[4][3] = {{1, 0, 0}, {0.5, 0.5, 0.5}, {0.5, -0.5, 0.5}, {0, 0, 1}};
  constexpr double G3[5][3] = {
      {2, 0, 0}, {1, 1, 1}, {-1.0 / 3, 1.0 / 3, -1.0 / 3}, {-8.0 / 3, -4.0 / 3, -2.0 / 3}, {0, 0, 1}};
  const double(*G)[3] = tile_ == 3 ? G3 : G2;
  const int rows = tile_ + 2, side = upsampled_ ? 3 : rows;
  constexpr int kUpsampledRow[3] = {0, 1, 3};
  kernels_.assign(static_cast<size_t>(side * side * inputs_ * outputs_), 0);
  const int64_t o_count = outputs_, i_count = inputs_;
  uint16_t* kernels = kernels_.data();
  at::parallel_for(0, inputs_, 8, [&](int64_t i0, int64_t i1) {
    std::vector<double> gk(static_cast<size_t>(3 * rows * o_count));  // G g: [row r][kernel column c][O]
    for (int64_t i = i0; i < i1; ++i) {
      const double* k = src + i * 9 * o_count;  // k[(3 * row + column) * O + o]
      for (int r = 0; r < rows; ++r)
        for (int c = 0; c < 3; ++c) {
          double* out = gk.data() + (r * 3 + c) * o_count;
          const double* k0 = k + c * o_count;
          const double* k1 = k + (3 + c) * o_count;
          const double* k2 = k + (6 + c) * o_count;
          for (int64_t o = 0; o < o_count; ++o) out[o] = G[r][0] * k0[o] + G[r][1] * k1[o] + G[r][2] * k2[o];
        }
      // Input i's place in the transformed inputs' order: the evens of its 32, then the odds.
      const int64_t in32 = i % 32, slot = i - in32 + (in32 % 2 == 0 ? in32 / 2 : 16 + in32 / 2);
      for (int pr = 0; pr < side; ++pr)
        for (int pc = 0; pc < side; ++pc) {
          const int r = upsampled_ ? kUpsampledRow[pr] : pr, c = upsampled_ ? kUpsampledRow[pc] : pc;
          const double scale = upsampled_ ? (r == 1 ? 2.0 : 1.0) * (c == 1 ? 2.0 : 1.0) : 1.0;
          const double* g0 = gk.data() + (r * 3) * o_count;
          const double* g1 = g0 + o_count;
          const double* g2 = g1 + o_count;
          const int64_t p = side * pr + pc;
          uint16_t* dst = kernels + ((p * (i_count / 2) + slot / 2) * o_count) * 2 + slot % 2;
          for (int64_t o = 0; o < o_count; ++o) {
            dst[2 * o] = to_bf16(static_cast<float>(scale * (g0[o] * G[c][0] + g1[o] * G[c][1] + g2[o] * G[c][2])));
          }
        }
    }
  });
  bias_ = conv_bias("WinogradConv3x3", bias, outputs_);
}

at::Tensor WinogradConv3x3::forward(const at::Tensor& input, bool relu, const at::Tensor& residual) const {
  if (input.dim() != 4 || input.size(1) != inputs_ || input.scalar_type() != at::kBFloat16) {
    fail("WinogradConv3x3: input must be bf16 [N, " + std::to_string(inputs_) + ", H, W], got " + shape_of(input));
  }
  if (!available()) {
    fail("WinogradConv3x3: not available (the CPU has no AVX512_BF16, or LRF_WINOGRAD=0 / LRF_FUSED_CONV=0 "
         "switched it off)");
  }
  const at::Tensor x = input.contiguous(at::MemoryFormat::ChannelsLast);
  const int64_t n = x.size(0), h = x.size(2), w = x.size(3);
  const int64_t out_h = upsampled_ ? 2 * h : h, out_w = upsampled_ ? 2 * w : w;
  at::Tensor out = conv_destination("WinogradConv3x3", x, residual, {n, outputs_, out_h, out_w});
  if (x.numel() == 0) return out;
#if defined(__x86_64__)
  const int64_t tiles_y = upsampled_ ? h : (h + tile_ - 1) / tile_, tiles_x = upsampled_ ? w : (w + tile_ - 1) / tile_;
  Geometry g{n, h, w, out_h, out_w, inputs_, outputs_, upsampled_, tile_, tiles_y, tiles_x, 0};
  g.units_per_row = (g.tiles_x + kTilesPerUnit - 1) / kTilesPerUnit;
  const auto* in = reinterpret_cast<const uint16_t*>(x.data_ptr());
  auto* dst = reinterpret_cast<uint16_t*>(out.data_ptr());
  run(g, in, kernels_.data(), bias_.data(), relu, residual.defined() ? dst : nullptr, dst);
#endif
  return out;
}

}  // namespace lrf
