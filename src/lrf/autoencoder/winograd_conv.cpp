#include "lrf/autoencoder/winograd_conv.h"

#include <algorithm>
#include <cstring>
#include <string>

#include <ATen/ATen.h>
#include <ATen/Parallel.h>

#include "lrf/autoencoder/bf16_vectors.h"
#include "lrf/autoencoder/conv_destination.h"
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

constexpr int kTilesPerUnit = 12;  // output tiles along a row transformed and multiplied together
constexpr int kTilesPerPass = 6;   // tiles whose 64 outputs are accumulated in registers: 6 x 4 zmm

#if defined(__x86_64__)
using bf16_vectors::kAll;
using bf16_vectors::load16;
using bf16_vectors::load32_split;
using bf16_vectors::store16;
using bf16_vectors::store32;

struct Geometry {
  int64_t n, in_h, in_w, out_h, out_w, inputs, outputs;
  bool upsampled;  // the input is upsampled 2x (nearest) before the convolution
  int tile;        // outputs per tile side: 2, or 3 for F(3x3, 3x3)
  int64_t tiles_y, tiles_x, units_per_row;
  // Products per tile: (tile + 2)², or 9 when upsampled.
  int positions() const { return upsampled ? 9 : (tile + 2) * (tile + 2); }
};

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

// Aᵀ m of F(3x3, 3x3) for one column (row) of five: Aᵀ's rows are (1, 1, 1, 1, 0), (0, 1, -1, ½, 0),
// (0, 1, 1, ¼, 1).
LRF_AVX512_BF16 inline void output_transform3(const __m512 m[5], __m512 s[3]) {
  const __m512 p = _mm512_add_ps(m[1], m[2]), q = _mm512_sub_ps(m[1], m[2]);
  s[0] = _mm512_add_ps(_mm512_add_ps(m[0], p), m[3]);
  s[1] = _mm512_fmadd_ps(_mm512_set1_ps(0.5f), m[3], q);
  s[2] = _mm512_add_ps(_mm512_fmadd_ps(_mm512_set1_ps(0.25f), m[3], p), m[4]);
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
        transform_inputs3(g, in, image, ty, tx0, tiles, v.data());
      } else if (g.upsampled) {
        transform_inputs<true>(g, in, image, ty, tx0, tiles, v.data());
      } else {
        transform_inputs<false>(g, in, image, ty, tx0, tiles, v.data());
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
        transform_outputs3(g, m.data(), bias, relu, residual, out, image, ty, tx0, tiles);
      } else if (g.upsampled) {
        transform_outputs<true>(g, m.data(), bias, relu, residual, out, image, ty, tx0, tiles);
      } else {
        transform_outputs<false>(g, m.data(), bias, relu, residual, out, image, ty, tx0, tiles);
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
  bias_.assign(static_cast<size_t>(outputs_), 0.f);
  if (bias.defined()) {
    if (bias.dim() != 1 || bias.size(0) != outputs_) fail("WinogradConv3x3: bias must be [O], got " + shape_of(bias));
    const at::Tensor b = bias.detach().to(at::kFloat).contiguous();
    std::copy(b.data_ptr<float>(), b.data_ptr<float>() + outputs_, bias_.begin());
  }
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
