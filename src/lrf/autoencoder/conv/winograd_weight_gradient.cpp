#include "lrf/autoencoder/conv/winograd_weight_gradient.h"

#include <algorithm>
#include <cstring>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include <ATen/ATen.h>
#include <ATen/Parallel.h>

#include "lrf/autoencoder/conv/bf16_vectors.h"
#include "lrf/autoencoder/conv/winograd_conv.h"
#include "lrf/core/error.h"

namespace lrf {
namespace {

// Pairs of horizontally neighbouring tiles whose transforms are made and summed together: their
// transformed inputs and gradients (16 positions x 64 tiles x 64 channels x 2 bytes, 128 KB each at 64
// channels) stay in the core's L2, and each float32 accumulator in registers is loaded and stored once
// per 32 dot products.
constexpr int kChunkPairs = 32;
constexpr int kPositions = 16;

// Tiles are paired along rows: pair (image, ty, px) is the tiles at output columns 4 px and 4 px + 2 of
// output rows 2 ty, 2 ty + 1, so that the two share two of their six input columns. A row of an odd
// number of tiles ends in a pair whose second tile lies outside the image: its gradient is zero, so it
// adds nothing.
struct Shape {
  int64_t n, h, w, inputs, outputs, tiles_y, pairs_x;
  int64_t pairs() const { return n * tiles_y * pairs_x; }
};

#if defined(__x86_64__)
using bf16_vectors::load32_half;

struct PairCorner {
  int64_t image, y, x;  // top-left output pixel of the pair's first tile
};

PairCorner corner_of(const Shape& s, int64_t pair) {
  const int64_t per_image = s.tiles_y * s.pairs_x;
  return {pair / per_image, 2 * (pair % per_image / s.pairs_x), 4 * (pair % s.pairs_x)};
}

// Rounds two tiles' 16 channels to bf16 and stores them interleaved, [channel][tile]: the pairs that the
// dot products sum over.
LRF_AVX512_BF16 inline void store_pair(uint16_t* p, __m512 first, __m512 second) {
  const __m512i both = reinterpret_cast<__m512i>(_mm512_cvtne2ps_pbh(second, first));  // first's 16, then second's
  const __m512i interleave = _mm512_set_epi16(31, 15, 30, 14, 29, 13, 28, 12, 27, 11, 26, 10, 25, 9, 24, 8, 23, 7,
                                              22, 6, 21, 5, 20, 4, 19, 3, 18, 2, 17, 1, 16, 0);
  _mm512_storeu_si512(p, _mm512_permutexvar_epi16(interleave, both));
}

// V = Bᵀ d B (winograd_conv.cpp's input transform) of a pair's two tiles, 32 channels from c, stored at
// v[p][slot][2] (p = 4 * row + column; slots: the evens of the 32, then the odds).
LRF_AVX512_BF16 void transform_inputs(const Shape& s, const uint16_t* in, const PairCorner& t, int64_t c,
                                      uint16_t* v, int64_t position_stride) {
  const uint16_t* at[4][6];  // the 4 x 6 input pixels' channels, null outside the image
  for (int i = 0; i < 4; ++i) {
    const int64_t y = t.y - 1 + i;
    for (int j = 0; j < 6; ++j) {
      const int64_t x = t.x - 1 + j;
      at[i][j] = y >= 0 && y < s.h && x >= 0 && x < s.w ? in + ((t.image * s.h + y) * s.w + x) * s.inputs + c : nullptr;
    }
  }
  const __m512 zero = _mm512_setzero_ps();
  for (int e = 0; e < 2; ++e) {
    __m512 r[6][4];  // Bᵀ d: [column][row]
    for (int j = 0; j < 6; ++j) {
      __m512 d[4];
      for (int i = 0; i < 4; ++i) d[i] = at[i][j] ? load32_half(at[i][j], e) : zero;
      r[j][0] = _mm512_sub_ps(d[0], d[2]);
      r[j][1] = _mm512_add_ps(d[1], d[2]);
      r[j][2] = _mm512_sub_ps(d[2], d[1]);
      r[j][3] = _mm512_sub_ps(d[1], d[3]);
    }
    for (int i = 0; i < 4; ++i) {
      __m512 q[2][4];  // (Bᵀ d) B of each tile: its columns 0-3 and 2-5
      for (int k = 0; k < 2; ++k) {
        const int j = 2 * k;
        q[k][0] = _mm512_sub_ps(r[j][i], r[j + 2][i]);
        q[k][1] = _mm512_add_ps(r[j + 1][i], r[j + 2][i]);
        q[k][2] = _mm512_sub_ps(r[j + 2][i], r[j + 1][i]);
        q[k][3] = _mm512_sub_ps(r[j + 1][i], r[j + 3][i]);
      }
      for (int jj = 0; jj < 4; ++jj) store_pair(v + (4 * i + jj) * position_stride + 32 * e, q[0][jj], q[1][jj]);
    }
  }
}

// dM = A dY Aᵀ of a pair's two tiles (the transpose of the output transform Y = Aᵀ M A, whose rows are
// y0 = m0 + m1 + m2 and y1 = m1 - m2 - m3), 32 channels from c, stored as transform_inputs stores, but
// with row and column 3 negated (they are -dY's second row or column; the sign is restored in dU).
// Adds the pair's dY into `bias` ([slot], 32 from c).
LRF_AVX512_BF16 void transform_gradients(const Shape& s, const uint16_t* g, const PairCorner& t, int64_t c,
                                         uint16_t* m, int64_t position_stride, float* bias) {
  const uint16_t* at[2][4];
  for (int a = 0; a < 2; ++a) {
    const int64_t y = t.y + a;
    for (int j = 0; j < 4; ++j) {
      const int64_t x = t.x + j;
      at[a][j] = y < s.h && x < s.w ? g + ((t.image * s.h + y) * s.w + x) * s.outputs + c : nullptr;
    }
  }
  const __m512 zero = _mm512_setzero_ps();
  for (int e = 0; e < 2; ++e) {
    __m512 sum = _mm512_loadu_ps(bias + c + 16 * e);
    __m512 r[4][4];  // A dY: [column][row]
    for (int j = 0; j < 4; ++j) {
      const __m512 y0 = at[0][j] ? load32_half(at[0][j], e) : zero, y1 = at[1][j] ? load32_half(at[1][j], e) : zero;
      sum = _mm512_add_ps(sum, _mm512_add_ps(y0, y1));
      r[j][0] = y0;
      r[j][1] = _mm512_add_ps(y0, y1);
      r[j][2] = _mm512_sub_ps(y0, y1);
      r[j][3] = y1;
    }
    _mm512_storeu_ps(bias + c + 16 * e, sum);
    for (int i = 0; i < 4; ++i) {
      __m512 q[2][4];
      for (int k = 0; k < 2; ++k) {
        const int j = 2 * k;
        q[k][0] = r[j][i];
        q[k][1] = _mm512_add_ps(r[j][i], r[j + 1][i]);
        q[k][2] = _mm512_sub_ps(r[j][i], r[j + 1][i]);
        q[k][3] = r[j + 1][i];
      }
      for (int jj = 0; jj < 4; ++jj) store_pair(m + (4 * i + jj) * position_stride + 32 * e, q[0][jj], q[1][jj]);
    }
  }
}

// Transforms a chunk's pairs into [position][pair][slot][2] bf16: `v` of the inputs, `m` of the
// gradients; adds the gradients' sum per slot into `bias`.
LRF_AVX512_BF16 void transform_chunk(const Shape& s, const uint16_t* in, const uint16_t* g, int64_t first_pair,
                                     int64_t pairs, uint16_t* v, uint16_t* m, float* bias) {
  for (int64_t q = 0; q < pairs; ++q) {
    const PairCorner t = corner_of(s, first_pair + q);
    for (int64_t c = 0; c < s.inputs; c += 32) {
      transform_inputs(s, in, t, c, v + (q * s.inputs + c) * 2, pairs * s.inputs * 2);
    }
    for (int64_t c = 0; c < s.outputs; c += 32) {
      transform_gradients(s, g, t, c, m + (q * s.outputs + c) * 2, pairs * s.outputs * 2, bias);
    }
  }
}

// du[o][k..k+64) += Σ_pairs m[pair][o] · v[pair][k..k+64) for `Rows` outputs from o, one position: each
// dot product takes a pair of tiles.
template <int Rows>
LRF_AVX512_BF16 void accumulate(const uint16_t* m, const uint16_t* v, int64_t pairs, int64_t outputs, int64_t inputs,
                                int64_t o, int64_t k, float* du) {
  __m512 acc[Rows][4];
  for (int r = 0; r < Rows; ++r)
    for (int j = 0; j < 4; ++j) acc[r][j] = _mm512_setzero_ps();
  for (int64_t q = 0; q < pairs; ++q) {
    const uint16_t* vq = v + (q * inputs + k) * 2;
    __m512bh b[4];
    for (int j = 0; j < 4; ++j) b[j] = reinterpret_cast<__m512bh>(_mm512_loadu_si512(vq + 32 * j));
    const uint16_t* mq = m + (q * outputs + o) * 2;
    for (int r = 0; r < Rows; ++r) {
      int32_t pair;
      std::memcpy(&pair, mq + 2 * r, sizeof pair);
      const __m512bh a = reinterpret_cast<__m512bh>(_mm512_set1_epi32(pair));
      for (int j = 0; j < 4; ++j) acc[r][j] = _mm512_dpbf16_ps(acc[r][j], a, b[j]);
    }
  }
  for (int r = 0; r < Rows; ++r) {
    float* row = du + (o + r) * inputs + k;
    for (int j = 0; j < 4; ++j) _mm512_storeu_ps(row + 16 * j, _mm512_add_ps(_mm512_loadu_ps(row + 16 * j), acc[r][j]));
  }
}

constexpr int kRowsPerPass = 6;  // outputs accumulated in registers: 6 x 4 zmm

LRF_AVX512_BF16 void accumulate_rows(int rows, const uint16_t* m, const uint16_t* v, int64_t pairs, int64_t outputs,
                                     int64_t inputs, int64_t o, int64_t k, float* du) {
  switch (rows) {
    case 1: return accumulate<1>(m, v, pairs, outputs, inputs, o, k, du);
    case 2: return accumulate<2>(m, v, pairs, outputs, inputs, o, k, du);
    case 3: return accumulate<3>(m, v, pairs, outputs, inputs, o, k, du);
    case 4: return accumulate<4>(m, v, pairs, outputs, inputs, o, k, du);
    case 5: return accumulate<5>(m, v, pairs, outputs, inputs, o, k, du);
    default: return accumulate<6>(m, v, pairs, outputs, inputs, o, k, du);
  }
}

// Σ over the chunks [begin, end) into du [16][O slots][I slots] and bias [O slots] (float32, added to).
LRF_AVX512_BF16 void sum_chunks(const Shape& s, const uint16_t* in, const uint16_t* g, int64_t begin, int64_t end,
                                float* du, float* bias) {
  std::vector<uint16_t> v(static_cast<size_t>(kPositions * kChunkPairs * s.inputs * 2));
  std::vector<uint16_t> m(static_cast<size_t>(kPositions * kChunkPairs * s.outputs * 2));
  for (int64_t chunk = begin; chunk < end; ++chunk) {
    const int64_t first = chunk * kChunkPairs;
    const int64_t pairs = std::min<int64_t>(kChunkPairs, s.pairs() - first);
    transform_chunk(s, in, g, first, pairs, v.data(), m.data(), bias);
    for (int p = 0; p < kPositions; ++p) {
      const uint16_t* vp = v.data() + p * pairs * s.inputs * 2;
      const uint16_t* mp = m.data() + p * pairs * s.outputs * 2;
      float* dup = du + p * s.outputs * s.inputs;
      for (int64_t k = 0; k < s.inputs; k += 64) {
        for (int64_t o = 0; o < s.outputs; o += kRowsPerPass) {
          accumulate_rows(static_cast<int>(std::min<int64_t>(kRowsPerPass, s.outputs - o)), mp, vp, pairs, s.outputs,
                          s.inputs, o, k, dup);
        }
      }
    }
  }
}
#endif

std::string shape_of(const at::Tensor& t) { return c10::str(t.sizes()); }

}  // namespace

bool winograd_weight_gradient_takes(int64_t outputs, int64_t inputs) {
  return outputs > 0 && inputs > 0 && outputs % 32 == 0 && inputs % 64 == 0;
}

ConvParameterGradients winograd_weight_gradient(const at::Tensor& input, const at::Tensor& grad_output) {
  if (input.dim() != 4 || grad_output.dim() != 4 || input.scalar_type() != at::kBFloat16 ||
      grad_output.scalar_type() != at::kBFloat16 || input.size(0) != grad_output.size(0) ||
      input.size(2) != grad_output.size(2) || input.size(3) != grad_output.size(3)) {
    fail("winograd_weight_gradient: needs bf16 [N, I, H, W] inputs and [N, O, H, W] output gradients, got " +
         shape_of(input) + " and " + shape_of(grad_output));
  }
  const int64_t inputs = input.size(1), outputs = grad_output.size(1);
  if (!winograd_weight_gradient_takes(outputs, inputs)) {
    fail("winograd_weight_gradient: needs a multiple of 64 inputs and of 32 outputs, got " + std::to_string(inputs) +
         " -> " + std::to_string(outputs));
  }
  if (!WinogradConv3x3::available()) fail("winograd_weight_gradient: not available (see WinogradConv3x3)");
  const at::Tensor x = input.contiguous(at::MemoryFormat::ChannelsLast);
  const at::Tensor dy = grad_output.contiguous(at::MemoryFormat::ChannelsLast);
  const int64_t tiles_x = (x.size(3) + 1) / 2;
  const Shape s{x.size(0), x.size(2), x.size(3), inputs, outputs, (x.size(2) + 1) / 2, (tiles_x + 1) / 2};
  std::vector<double> du(static_cast<size_t>(kPositions * outputs * inputs), 0.0), bias(outputs, 0.0);
#if defined(__x86_64__)
  const int64_t chunks = (s.pairs() + kChunkPairs - 1) / kChunkPairs;
  const auto* in = reinterpret_cast<const uint16_t*>(x.data_ptr());
  const auto* g = reinterpret_cast<const uint16_t*>(dy.data_ptr());
  // Each thread sums its own range of chunks; the partial sums are added in the order of their ranges,
  // so the result does not depend on which thread finishes first.
  std::mutex lock;
  std::map<int64_t, std::pair<std::vector<float>, std::vector<float>>> partial;
  at::parallel_for(0, chunks, 1, [&](int64_t begin, int64_t end) {
    std::vector<float> part(du.size(), 0.f), part_bias(static_cast<size_t>(outputs), 0.f);
    sum_chunks(s, in, g, begin, end, part.data(), part_bias.data());
    const std::lock_guard<std::mutex> hold(lock);
    partial.emplace(begin, std::make_pair(std::move(part), std::move(part_bias)));
  });
  for (const auto& [begin, sums] : partial) {
    for (size_t k = 0; k < du.size(); ++k) du[k] += sums.first[k];
    for (int64_t o = 0; o < outputs; ++o) bias[o] += sums.second[o];
  }
#endif
  // dW = Gᵀ dU G, in float64 from the float32 sums: (dU G) first, 84 multiply-adds per kernel. Row 3 of
  // G is negated, since dM's row and column 3 were stored negated. dU and the bias are in slot order.
  constexpr double G[4][3] = {{1, 0, 0}, {0.5, 0.5, 0.5}, {0.5, -0.5, 0.5}, {0, 0, -1}};
  auto channel_of = [](int64_t slot) {
    const int64_t r = slot % 32;
    return slot - r + (r < 16 ? 2 * r : 2 * (r - 16) + 1);
  };
  at::Tensor weight = at::empty({outputs, inputs, 3, 3}, at::kFloat);
  float* w = weight.data_ptr<float>();
  const int64_t plane = outputs * inputs;
  const double* sums = du.data();
  at::parallel_for(0, plane, 512, [&](int64_t begin, int64_t end) {
    for (int64_t oi = begin; oi < end; ++oi) {
      double ug[4][3];
      for (int r = 0; r < 4; ++r)
        for (int b = 0; b < 3; ++b) {
          double sum = 0;
          for (int c = 0; c < 4; ++c) sum += sums[(4 * r + c) * plane + oi] * G[c][b];
          ug[r][b] = sum;
        }
      float* kernel = w + (channel_of(oi / inputs) * inputs + channel_of(oi % inputs)) * 9;
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
          double sum = 0;
          for (int r = 0; r < 4; ++r) sum += G[r][a] * ug[r][b];
          kernel[3 * a + b] = static_cast<float>(sum);
        }
    }
  });
  at::Tensor bias_grad = at::empty({outputs}, at::kFloat);
  float* db = bias_grad.data_ptr<float>();
  for (int64_t slot = 0; slot < outputs; ++slot) db[channel_of(slot)] = static_cast<float>(bias[slot]);
  return {weight, bias_grad};
}

}  // namespace lrf
