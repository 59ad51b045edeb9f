#include "lrf/autoencoder/conv/winograd_tiles.h"

#if defined(__x86_64__)
#include "lrf/autoencoder/conv/bf16_vectors.h"

namespace lrf::winograd {
namespace {

using bf16_vectors::kAll;
using bf16_vectors::load16;
using bf16_vectors::load32_split;
using bf16_vectors::store32;

// V = Bᵀ d B for the unit's tiles: v[p][t][k], p = 4 * row + column. 32 input channels are loaded at a
// time as their even and odd halves, and stored so: k runs over the evens of each 32 then the odds
// (the transformed kernels follow the same order). Neighbouring tiles share input columns, so each
// column's vertical transform (Bᵀ d) is done once.
// On a 2x upsampled input the tile at input pixel (ty, tx) is output rows 2ty, 2ty + 1 (and columns
// likewise), whose 4x4 patch repeats the middle input row: d = (x[ty - 1], x[ty], x[ty], x[ty + 1]). Then
// Bᵀ d = (x[ty - 1] - x[ty], 2 x[ty], 0, x[ty] - x[ty + 1]): row 2 of V and column 2 vanish, leaving 9
// products instead of 16 (p = 3 * row + column over rows and columns 0, 1, 3), and the factors 2 go
// into the transformed kernels.
template <bool Upsampled>
LRF_AVX512_BF16 void transform_inputs(const Geometry& g, const uint16_t* in, int64_t image, int64_t ty, int64_t tx0,
                                      int tiles, uint16_t* v) {
  constexpr int kRows = Upsampled ? 3 : 4;
  const __m512 zero = _mm512_setzero_ps();
  const int64_t x_first = Upsampled ? tx0 - 1 : 2 * tx0 - 1, y0 = Upsampled ? ty - 1 : 2 * ty - 1;
  const int columns = Upsampled ? tiles + 2 : 2 * tiles + 2;
  bool row_inside[kRows];
  for (int i = 0; i < kRows; ++i) row_inside[i] = y0 + i >= 0 && y0 + i < g.in_h;
  const int64_t stride = static_cast<int64_t>(kTilesPerUnit) * g.inputs;
  // The last kRows columns' Bᵀ d, [column % kRows][row][even, odd channels]: each tile is transformed
  // across as soon as its last column is in, while its columns are still in registers or L1.
  constexpr int kStep = Upsampled ? 1 : 2;  // columns from one tile to the next
  __m512 r[kRows][4][2];
  for (int64_t c = 0; c < g.inputs; c += 32) {
    for (int j = 0; j < columns; ++j) {
      const int64_t x = x_first + j;
      __m512 d[kRows][2];
      for (int i = 0; i < kRows; ++i) {
        if (row_inside[i] && x >= 0 && x < g.in_w) {
          load32_split(in + ((image * g.in_h + y0 + i) * g.in_w + x) * g.inputs + c, d[i]);
        } else {
          d[i][0] = d[i][1] = zero;
        }
      }
      __m512(*rj)[2] = r[j % kRows];
      for (int e = 0; e < 2; ++e) {
        if constexpr (Upsampled) {
          rj[0][e] = _mm512_sub_ps(d[0][e], d[1][e]);
          rj[1][e] = d[1][e];
          rj[2][e] = _mm512_sub_ps(d[1][e], d[2][e]);
        } else {
          rj[0][e] = _mm512_sub_ps(d[0][e], d[2][e]);
          rj[1][e] = _mm512_add_ps(d[1][e], d[2][e]);
          rj[2][e] = _mm512_sub_ps(d[2][e], d[1][e]);
          rj[3][e] = _mm512_sub_ps(d[1][e], d[3][e]);
        }
      }
      if (j < kRows - 1 || (j - (kRows - 1)) % kStep != 0) continue;
      const int t = (j - (kRows - 1)) / kStep;  // columns kStep t .. kStep t + kRows - 1 are in
      const __m512(*col[kRows])[2];
      for (int k = 0; k < kRows; ++k) col[k] = r[(kStep * t + k) % kRows];
      uint16_t* out = v + t * g.inputs + c;
      for (int i = 0; i < kRows; ++i) {
        __m512 q[4][2];
        for (int e = 0; e < 2; ++e) {
          if constexpr (Upsampled) {
            q[0][e] = _mm512_sub_ps(col[0][i][e], col[1][i][e]);
            q[1][e] = col[1][i][e];
            q[2][e] = _mm512_sub_ps(col[1][i][e], col[2][i][e]);
          } else {
            q[0][e] = _mm512_sub_ps(col[0][i][e], col[2][i][e]);
            q[1][e] = _mm512_add_ps(col[1][i][e], col[2][i][e]);
            q[2][e] = _mm512_sub_ps(col[2][i][e], col[1][i][e]);
            q[3][e] = _mm512_sub_ps(col[1][i][e], col[3][i][e]);
          }
        }
        for (int jj = 0; jj < kRows; ++jj) store32(out + (kRows * i + jj) * stride, q[jj][0], q[jj][1]);
      }
    }
  }
}

// Y = Aᵀ M A per tile and 32 outputs, + bias (+ residual), ReLU, rounded to bf16 and stored. Upsampled,
// M's row and column 2 are zero and the 9 others are stored 3 to a row.
template <bool Upsampled>
LRF_AVX512_BF16 void transform_outputs(const Geometry& g, const float* m, const float* bias, bool relu,
                                       const uint16_t* residual, uint16_t* out, int64_t image, int64_t ty, int64_t tx0,
                                       int tiles) {
  const int64_t stride = static_cast<int64_t>(kTilesPerUnit) * g.outputs;
  const __m512 zero = _mm512_setzero_ps();
  for (int t = 0; t < tiles; ++t) {
    for (int64_t c = 0; c < g.outputs; c += 32) {
      __m512 y[2][2][2];  // [row][column][16 outputs]
      for (int h = 0; h < 2; ++h) {
        const float* src = m + t * g.outputs + c + 16 * h;
        const __m512 b = _mm512_loadu_ps(bias + c + 16 * h);
        if constexpr (Upsampled) {
          __m512 s[2][3];
          for (int j = 0; j < 3; ++j) {
            const __m512 m0 = _mm512_loadu_ps(src + (0 + j) * stride), m1 = _mm512_loadu_ps(src + (3 + j) * stride);
            const __m512 m3 = _mm512_loadu_ps(src + (6 + j) * stride);
            s[0][j] = _mm512_add_ps(m0, m1);
            s[1][j] = _mm512_sub_ps(m1, m3);
          }
          for (int a = 0; a < 2; ++a) {
            y[a][0][h] = _mm512_add_ps(_mm512_add_ps(s[a][0], s[a][1]), b);
            y[a][1][h] = _mm512_add_ps(_mm512_sub_ps(s[a][1], s[a][2]), b);
          }
        } else {
          __m512 s[2][4];
          for (int j = 0; j < 4; ++j) {
            const __m512 m0 = _mm512_loadu_ps(src + (0 + j) * stride), m1 = _mm512_loadu_ps(src + (4 + j) * stride);
            const __m512 m2 = _mm512_loadu_ps(src + (8 + j) * stride), m3 = _mm512_loadu_ps(src + (12 + j) * stride);
            s[0][j] = _mm512_add_ps(_mm512_add_ps(m0, m1), m2);
            s[1][j] = _mm512_sub_ps(_mm512_sub_ps(m1, m2), m3);
          }
          for (int a = 0; a < 2; ++a) {
            y[a][0][h] = _mm512_add_ps(_mm512_add_ps(_mm512_add_ps(s[a][0], s[a][1]), s[a][2]), b);
            y[a][1][h] = _mm512_add_ps(_mm512_sub_ps(_mm512_sub_ps(s[a][1], s[a][2]), s[a][3]), b);
          }
        }
      }
      for (int a = 0; a < 2; ++a) {
        const int64_t row = 2 * ty + a;
        if (row >= g.out_h) break;
        for (int e = 0; e < 2; ++e) {
          const int64_t x = 2 * (tx0 + t) + e;
          if (x >= g.out_w) break;
          const int64_t at = ((image * g.out_h + row) * g.out_w + x) * g.outputs + c;
          __m512 low = y[a][e][0], high = y[a][e][1];
          if (residual) {
            low = _mm512_add_ps(low, load16(residual + at));
            high = _mm512_add_ps(high, load16(residual + at + 16));
          }
          if (relu) low = _mm512_maskz_max_ps(kAll, low, zero), high = _mm512_maskz_max_ps(kAll, high, zero);
          store32(out + at, low, high);
        }
      }
    }
  }
}

}  // namespace

LRF_AVX512_BF16 void transform_inputs2(const Geometry& g, const uint16_t* in, int64_t image, int64_t ty, int64_t tx0,
                                       int tiles, uint16_t* v) {
  if (g.upsampled) {
    transform_inputs<true>(g, in, image, ty, tx0, tiles, v);
  } else {
    transform_inputs<false>(g, in, image, ty, tx0, tiles, v);
  }
}

LRF_AVX512_BF16 void transform_outputs2(const Geometry& g, const float* m, const float* bias, bool relu,
                                        const uint16_t* residual, uint16_t* out, int64_t image, int64_t ty,
                                        int64_t tx0, int tiles) {
  if (g.upsampled) {
    transform_outputs<true>(g, m, bias, relu, residual, out, image, ty, tx0, tiles);
  } else {
    transform_outputs<false>(g, m, bias, relu, residual, out, image, ty, tx0, tiles);
  }
}

}  // namespace lrf::winograd
#endif
