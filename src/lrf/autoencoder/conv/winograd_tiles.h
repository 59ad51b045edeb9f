#pragma once
// The input and output transforms of the Winograd convolution (winograd_conv.h), for one unit of up to
// kTilesPerUnit output tiles along a row: F(2x2, 3x3), of a plain or a 2x upsampled input
// (winograd_tiles2x2.cpp), and F(3x3, 3x3) (winograd_tiles3x3.cpp). Between them the convolution
// multiplies, at each position p of the transformed patches, V[p] (tiles x inputs) by U[p] (inputs x
// outputs). Compiled for AVX512_BF16; callers check WinogradConv3x3::available() first.
#include <cstdint>

namespace lrf::winograd {

constexpr int kTilesPerUnit = 12;  // output tiles along a row transformed and multiplied together

struct Geometry {
  int64_t n, in_h, in_w, out_h, out_w, inputs, outputs;
  bool upsampled;  // the input is upsampled 2x (nearest) before the convolution
  int tile;        // outputs per tile side: 2, or 3 for F(3x3, 3x3)
  int64_t tiles_y, tiles_x, units_per_row;
  // Products per tile: (tile + 2)², or 9 when upsampled.
  int positions() const { return upsampled ? 9 : (tile + 2) * (tile + 2); }
};

#if defined(__x86_64__)
// V = Bᵀ d B for the unit's tiles: v[p][t][k], bf16, k over the inputs, each 32 the evens then the odds
// (the order of the transformed kernels' pairs). The unit is image `image`, tile row ty, tiles tx0 ..
// tx0 + tiles - 1; positions stride kTilesPerUnit * inputs apart.
void transform_inputs2(const Geometry& g, const uint16_t* in, int64_t image, int64_t ty, int64_t tx0, int tiles,
                       uint16_t* v);
void transform_inputs3(const Geometry& g, const uint16_t* in, int64_t image, int64_t ty, int64_t tx0, int tiles,
                       uint16_t* v);

// Y = Aᵀ M A for the unit's tiles from m[p][t][o] (float32, positions kTilesPerUnit * outputs apart), +
// bias, + the residual where given (read from `residual`, which may be `out`), the ReLU when `relu`,
// rounded to bf16 into the channels-last output.
void transform_outputs2(const Geometry& g, const float* m, const float* bias, bool relu, const uint16_t* residual,
                        uint16_t* out, int64_t image, int64_t ty, int64_t tx0, int tiles);
void transform_outputs3(const Geometry& g, const float* m, const float* bias, bool relu, const uint16_t* residual,
                        uint16_t* out, int64_t image, int64_t ty, int64_t tx0, int tiles);
#endif

}  // namespace lrf::winograd
