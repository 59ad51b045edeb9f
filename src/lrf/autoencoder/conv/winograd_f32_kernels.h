#pragma once
// The float32 Winograd kernels behind winograd_f32.h, over raw channels-last arrays: one implementation
// (winograd_f32_kernels.inc) compiled once per vector width, for AVX2 with FMA (8 lanes) and for
// AVX-512F (16 lanes), each file with its own -m flags so that the rest of the build stays baseline
// x86-64 and the CPU's widest path is chosen at run time (winograd_f32.cpp). No libtorch here.
#include <cstdint>

namespace lrf::winograd_f32 {

// Output tiles handled per unit: a unit is a run of this many tiles along one tile row, whose patches go
// through the input transform, the products and the output transform together while in cache. Each unit
// streams every transformed kernel once (36 x 64 x 64 floats for F(4x4) of 64 channels, beyond L2), so
// longer units stream them less often; a 64->64 convolution at 504x376 on the 2-core AVX2 EPYC took
// 40.5-41.2 ms with 12 tiles, 39.2 with 24, 36.0 with 36, 41.8 with 48 and 39.5 with 72 (bench_autoencoder
// conv, one run each). With the positions' blocks a cache line off a power of two apart (position_stride in
// the kernels), 24, 32, 48 and 64 tiles all took 70-75 ms on one thread there. On an AMD EPYC with
// AVX-512 (1 MiB of L2 a core) 16 tiles beat 32 by 1.04-1.09x on the whole networks (decode, encode, the
// refinement's decoder share, Stage I and III steps; bench_autoencoder paths, alternated): a unit's
// transformed inputs and products (2 x 36 positions x 16 tiles x 64 channels) stay in L2 beside the
// 576 KiB of transformed kernels each unit streams.
constexpr int kTilesPerUnit = 16;

struct Geometry {
  int64_t n, in_h, in_w, out_h, out_w, inputs, outputs;
  bool upsampled;  // the convolution reads the input upsampled 2x (nearest): out = 2 x in, read at [y/2][x/2]
  int tile;        // outputs per tile side: 2, 4 or 6, F(m x m, 3x3)
  int64_t tiles_y, tiles_x, units_per_row;
  int side() const { return tile + 2; }
  int positions() const { return side() * side(); }
  int64_t units() const { return n * tiles_y * units_per_row; }
};

struct Kernels {
  int lanes;  // floats per vector: channel counts must be multiples of it
  // Units [begin, end) of out = relu?(conv(in) + bias + residual): in [n][in_h][in_w][inputs], out and
  // residual (may be null, may equal out) [n][out_h][out_w][outputs], u the transformed kernels
  // [positions][inputs][outputs], bias [outputs].
  void (*forward)(const Geometry& g, const float* in, const float* u, const float* bias, bool relu,
                  const float* residual, float* out, int64_t begin, int64_t end);
  // Units [begin, end) of the transformed kernels' gradient, added into du [positions][outputs][inputs]:
  // du[p] += Σ_tiles (A dY Aᵀ)[p]ᵀ (Bᵀ d B)[p] for the input d and the output gradient dY (shaped as out).
  void (*weight_gradient)(const Geometry& g, const float* in, const float* grad_out, float* du, int64_t begin,
                          int64_t end);
};

#if defined(__x86_64__)
const Kernels& avx2_kernels();
const Kernels& avx512_kernels();
#endif

}  // namespace lrf::winograd_f32
