#include "lrf/autoencoder/conv/winograd_tiles.h"

#if defined(__x86_64__)
#include "lrf/autoencoder/conv/bf16_vectors.h"

namespace lrf::winograd {
namespace {

using bf16_vectors::kAll;
using bf16_vectors::load16;
using bf16_vectors::load32_split;
using bf16_vectors::store16;
using bf16_vectors::store32;

// Bᵀ d of F(3x3, 3x3) over the points 0, 1, -1, ½ and ∞ for one column (row) of five: Bᵀ's rows are
// (½, -1, -½, 1, 0), (0, -½, ½, 1, 0), (0, ½, -3/2, 1, 0), (0, -1, 0, 1, 0), (0, ½, -1, -½, 1), which share
// d2 - d1 and d3 - d1. With 2 or -2 for ½ the rounding error simulated alike (1.44-1.48 % rms per
// convolution); ½ keeps the transformed kernels' coefficients at most 8/3.
LRF_AVX512_BF16 inline void input_transform3(const __m512 d[5], __m512 r[5]) {
  const __m512 half = _mm512_set1_ps(0.5f);
  const __m512 a = _mm512_sub_ps(d[2], d[1]), b = _mm512_sub_ps(d[3], d[1]);
  r[0] = _mm512_fmadd_ps(half, _mm512_sub_ps(d[0], d[2]), b);
  r[1] = _mm512_fmadd_ps(half, a, d[3]);
  r[2] = _mm512_fnmadd_ps(half, a, _mm512_sub_ps(d[3], d[2]));
  r[3] = b;
  r[4] = _mm512_fnmadd_ps(half, b, _mm512_sub_ps(d[4], d[2]));
}

// Aᵀ m of F(3x3, 3x3) for one column (row) of five: Aᵀ's rows are (1, 1, 1, 1, 0), (0, 1, -1, ½, 0),
// (0, 1, 1, ¼, 1).
LRF_AVX512_BF16 inline void output_transform3(const __m512 m[5], __m512 s[3]) {
  const __m512 p = _mm512_add_ps(m[1], m[2]), q = _mm512_sub_ps(m[1], m[2]);
  s[0] = _mm512_add_ps(_mm512_add_ps(m[0], p), m[3]);
  s[1] = _mm512_fmadd_ps(_mm512_set1_ps(0.5f), m[3], q);
  s[2] = _mm512_add_ps(_mm512_fmadd_ps(_mm512_set1_ps(0.25f), m[3], p), m[4]);
}

}  // namespace

// transform_inputs for F(3x3, 3x3): 3x3 output tiles, whose 5x5 input patches overlap their neighbours'
// by two columns (and rows); 25 positions, p = 5 * row + column.
LRF_AVX512_BF16 void transform_inputs3(const Geometry& g, const uint16_t* in, int64_t image, int64_t ty, int64_t tx0,
                                       int tiles, uint16_t* v) {
  const __m512 zero = _mm512_setzero_ps();
  const int64_t x_first = 3 * tx0 - 1, y0 = 3 * ty - 1;
  const int columns = 3 * tiles + 2;
  bool row_inside[5];
  for (int i = 0; i < 5; ++i) row_inside[i] = y0 + i >= 0 && y0 + i < g.in_h;
  const int64_t stride = static_cast<int64_t>(kTilesPerUnit) * g.inputs;
  // The last five columns' Bᵀ d, [column % 5][even, odd channels][row]: each tile is transformed across as
  // soon as its last column is in, while its columns are still in registers or L1.
  __m512 r[5][2][5];
  for (int64_t c = 0; c < g.inputs; c += 32) {
    for (int j = 0; j < columns; ++j) {
      const int64_t x = x_first + j;
      __m512 d[2][5];
      for (int i = 0; i < 5; ++i) {
        if (row_inside[i] && x >= 0 && x < g.in_w) {
          __m512 halves[2];
          load32_split(in + ((image * g.in_h + y0 + i) * g.in_w + x) * g.inputs + c, halves);
          d[0][i] = halves[0], d[1][i] = halves[1];
        } else {
          d[0][i] = d[1][i] = zero;
        }
      }
      for (int e = 0; e < 2; ++e) input_transform3(d[e], r[j % 5][e]);
      if (j < 4 || (j - 4) % 3 != 0) continue;
      const int t = (j - 4) / 3;  // columns 3t .. 3t + 4 are in
      uint16_t* out = v + t * g.inputs + c;
      for (int i = 0; i < 5; ++i) {
        __m512 q[2][5];
        for (int e = 0; e < 2; ++e) {
          __m512 row[5];
          for (int k = 0; k < 5; ++k) row[k] = r[(3 * t + k) % 5][e][i];
          input_transform3(row, q[e]);
        }
        for (int jj = 0; jj < 5; ++jj) store32(out + (5 * i + jj) * stride, q[0][jj], q[1][jj]);
      }
    }
  }
}

// transform_outputs for F(3x3, 3x3), 16 outputs at a time (32 would not fit the registers: 15 partial
// sums and 18 results).
LRF_AVX512_BF16 void transform_outputs3(const Geometry& g, const float* m, const float* bias, bool relu,
                                        const uint16_t* residual, uint16_t* out, int64_t image, int64_t ty,
                                        int64_t tx0, int tiles) {
  const int64_t stride = static_cast<int64_t>(kTilesPerUnit) * g.outputs;
  const __m512 zero = _mm512_setzero_ps();
  for (int t = 0; t < tiles; ++t) {
    for (int64_t c = 0; c < g.outputs; c += 16) {
      const float* src = m + t * g.outputs + c;
      __m512 s[3][5];  // Aᵀ M: [row][column]
      for (int j = 0; j < 5; ++j) {
        __m512 column[5], rows[3];
        for (int i = 0; i < 5; ++i) column[i] = _mm512_loadu_ps(src + (5 * i + j) * stride);
        output_transform3(column, rows);
        for (int a = 0; a < 3; ++a) s[a][j] = rows[a];
      }
      const __m512 b = _mm512_loadu_ps(bias + c);
      for (int a = 0; a < 3; ++a) {
        const int64_t row = 3 * ty + a;
        if (row >= g.out_h) break;
        __m512 y[3];
        output_transform3(s[a], y);
        for (int e = 0; e < 3; ++e) {
          const int64_t x = 3 * (tx0 + t) + e;
          if (x >= g.out_w) break;
          const int64_t at = ((image * g.out_h + row) * g.out_w + x) * g.outputs + c;
          __m512 sum = _mm512_add_ps(y[e], b);
          if (residual) sum = _mm512_add_ps(sum, load16(residual + at));
          if (relu) sum = _mm512_maskz_max_ps(kAll, sum, zero);
          store16(out + at, sum);
        }
      }
    }
  }
}

}  // namespace lrf::winograd
#endif
