#pragma once
// A bf16 3x3 convolution (stride 1, zero padding 1) to a few output channels: the decoders' last layer,
// 64 -> 3 at full resolution. oneDNN's direct kernel computes 16 outputs for every 3 there and reached
// 68 GFLOP/s, 15 % of the dot products' peak, taking 10 ms of a 504x376 decode. Here each output's sum
// runs along the input channels instead: AVX512_BF16 dot products of 32 channels of a pixel with 32
// weights, 8 pixels x O outputs accumulated in registers over the 9 taps, then each vector's 16 lanes
// added up. Products in bf16, sums in float32, as the direct convolution's; only the order of the sums
// differs.
#include <cstdint>
#include <vector>

#include <ATen/core/Tensor.h>

namespace lrf {

class NarrowConv3x3 {
 public:
  // Channel counts it handles: 1 to 3 outputs, inputs a multiple of 32.
  static bool takes(int64_t outputs, int64_t inputs);
  // Whether this CPU runs it (AVX512_BF16) and the project's own kernels are on (fused_conv_enabled()).
  static bool available();

  // weight [O, I, 3, 3], bias [O] or undefined (any dtype and layout; copied).
  NarrowConv3x3(const at::Tensor& weight, const at::Tensor& bias);

  // input [N, I, H, W] bf16 -> [N, O, H, W] bf16 channels-last: conv + bias, then + `residual` when
  // defined, then the ReLU when `relu`. A defined residual must be channels-last bf16 of the output's
  // shape, must not overlap the input, and receives the result (it is returned). Needs available().
  at::Tensor forward(const at::Tensor& input, bool relu, const at::Tensor& residual = {}) const;

 private:
  int64_t outputs_ = 0, inputs_ = 0;
  std::vector<uint16_t> weights_;  // bf16 [O][9 taps][I]
  std::vector<float> bias_;        // [O], zeros for a layer without bias
};

}  // namespace lrf
