#pragma once
// A 3x3 convolution (stride 1, zero padding 1) of bf16 channels-last images by Winograd's F(2x2, 3x3):
// each 2x2 block of outputs is 16 products of transformed 4x4 input patches with transformed kernels,
// where the direct convolution needs 36, so 4/9 of the multiply-adds; or by F(3x3, 3x3), 25 products of
// 5x5 patches per 3x3 block, 25/81. The transforms are done in float32 on 32 channels at a time; the
// products are AVX512_BF16 dot products of bf16 pairs accumulated in float32, as oneDNN's bf16 direct
// convolution does. Input transform, the matrix products and output transform run on a dozen tiles at a
// time, so that everything in between stays in the core's caches.
// Accuracy: the transformed inputs and kernels are rounded to bf16 instead of the inputs and kernels
// themselves, and the output transform adds up 16 (25) such products per output with cancellation, so
// the error is a small multiple of the direct bf16 convolution's: ~2.5x with 2x2 tiles, ~7x with 3x3
// tiles (test_fused_conv measures them against float64).
#include <cstdint>
#include <vector>

#include <ATen/core/Tensor.h>

namespace lrf {

class WinogradConv3x3 {
 public:
  // Channel counts the kernel handles: inputs a multiple of 32, outputs a multiple of 64.
  static bool takes(int64_t outputs, int64_t inputs);
  // Whether this CPU runs it (AVX512_BF16 with the OS saving AVX-512 state) and it is not switched off
  // (winograd_enabled(), cpu_features.h).
  static bool available();

  // Output tiles: F(2x2, 3x3) takes 16 products per 4 outputs; F(3x3, 3x3) takes 25 per 9 (0.69x as many
  // per output) at about 3x the rounding error, which the decoded images still absorb (docs/speed.md).
  enum class Tiles { f2x2, f3x3 };
  // The tiles asked for: winograd_tile() (cpu_features.h), 3x3 unless $LRF_WINOGRAD_TILE=2.
  static Tiles chosen_tiles();

  // weight [O, I, 3, 3], bias [O] or undefined (any dtype and layout; copied). `upsampled_input`: the
  // convolution of the input upsampled 2x (nearest), computed from the input itself with 9 products per
  // 2x2 outputs instead of 16, since the upsampled 4x4 patches repeat their middle rows and columns
  // (2x2 tiles only).
  WinogradConv3x3(const at::Tensor& weight, const at::Tensor& bias, bool upsampled_input = false,
                  Tiles tiles = Tiles::f2x2);

  // input [N, I, H, W] bf16 -> [N, O, H, W] (upsampled: [N, O, 2H, 2W]) bf16 channels-last: conv + bias,
  // then + `residual` when defined, then the ReLU when `relu`. A defined residual must be channels-last
  // bf16 of the output's shape, must not overlap the input, and receives the result (it is returned).
  // Needs available().
  at::Tensor forward(const at::Tensor& input, bool relu, const at::Tensor& residual = {}) const;

 private:
  int64_t outputs_ = 0, inputs_ = 0;
  bool upsampled_ = false;
  int tile_ = 2;  // outputs per tile side
  // bf16 [16 positions][I / 2][O][2]: transformed, in pairs of inputs, each 32 inputs ordered evens first
  // (25 positions with 3x3 tiles; 9, rows and columns 0, 1, 3, when upsampled)
  std::vector<uint16_t> kernels_;
  std::vector<float> bias_;        // [O], zeros for a layer without bias
};

}  // namespace lrf
