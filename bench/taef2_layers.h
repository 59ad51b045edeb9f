#pragma once
// TAEF2's convolutions one by one (tiny_ae.cpp), for the benches' bounds and floors: each layer's direct
// multiply-adds and which of the project's Winograd kernels take it, so that the products an algorithm
// still needs can be counted per pass.
//  - bf16 (AVX512_BF16): inference takes 3x3 stride-1 convolutions of multiples of 32 inputs and 64
//    outputs (an upsampled one on 2x2 tiles, 9 products per 4 outputs), training those of 64 channels
//    both ways; the weight gradient runs on F(2x2) tiles.
//  - float32 (AVX2 or AVX-512F): every 3x3 stride-1 convolution whose channels are multiples of the
//    vector's lanes, in inference and in all three training passes, on F(4x4) tiles (36 products per 16
//    outputs, upsampled inputs read in place alike).
#include <vector>

namespace bench {

constexpr double kConv64 = 64.0 * 64 * 9;  // one 3x3 64->64 convolution, per output pixel
constexpr double kPool = 2.0 * 64 * 256;   // one pool branch (1x1 64->256->64), per latent cell

struct ConvLayer {
  double macs;  // direct multiply-adds, at the output's resolution
  enum Bf16Inference { winograd, upsampled, direct } bf16_inference;
  bool bf16_trained;  // bf16 training runs it as Winograd
  bool same_3x3;      // a 3x3 convolution of stride 1 (the float32 kernels' shape)
  int inputs, outputs;
};

inline std::vector<ConvLayer> taef2_encoder_layers(int w, int h) {
  const double p = static_cast<double>(w) * h;
  std::vector<ConvLayer> layers = {{3.0 * 64 * 9 * p, ConvLayer::direct, false, true, 3, 64}};
  auto block = [&](double pixels, bool pool) {
    for (int i = 0; i < 3; ++i) layers.push_back({kConv64 * pixels, ConvLayer::winograd, true, true, 64, 64});
    if (pool) layers.push_back({kPool * pixels, ConvLayer::direct, false, false, 64, 64});
  };
  block(p, false);
  for (int level = 1; level <= 3; ++level) {
    const double pixels = p / (1 << (2 * level));
    layers.push_back({kConv64 * pixels, ConvLayer::direct, false, false, 64, 64});  // stride 2
    for (int b = 0; b < 3; ++b) block(pixels, level == 3);
  }
  layers.push_back({64.0 * 32 * 9 * p / 64, ConvLayer::direct, false, true, 64, 32});
  return layers;
}

inline std::vector<ConvLayer> taef2_decoder_layers(int w, int h) {
  const double p = static_cast<double>(w) * h;
  std::vector<ConvLayer> layers = {{32.0 * 64 * 9 * p / 64, ConvLayer::winograd, false, true, 32, 64}};
  auto block = [&](double pixels, bool pool) {
    for (int i = 0; i < 3; ++i) layers.push_back({kConv64 * pixels, ConvLayer::winograd, true, true, 64, 64});
    if (pool) layers.push_back({kPool * pixels, ConvLayer::direct, false, false, 64, 64});
  };
  for (int level = 3; level >= 1; --level) {
    for (int b = 0; b < 3; ++b) block(p / (1 << (2 * level)), level == 3);
    layers.push_back({kConv64 * p / (1 << (2 * (level - 1))), ConvLayer::upsampled, true, true, 64, 64});
  }
  block(p, false);
  layers.push_back({64.0 * 3 * 9 * p, ConvLayer::direct, false, true, 64, 3});
  return layers;
}

inline double direct_flops(const std::vector<ConvLayer>& layers) {
  double sum = 0;
  for (const auto& l : layers) sum += 2 * l.macs;
  return sum;
}

// How the products of a pass are counted.
struct Algorithm {
  bool bf16;         // the bf16 kernels' rules, else the float32 ones
  int lanes;         // float32: the vector's lanes (8 or 16); 0 for no Winograd at all (direct convolutions)
  double tile_share; // products per direct multiply-add on Winograd's tiles: bf16 25/81 or 16/36, F(4x4) 1/4

  bool fp32_takes(const ConvLayer& l) const {
    return !bf16 && lanes > 0 && l.same_3x3 && l.inputs % lanes == 0 && l.outputs % lanes == 0;
  }
};

inline double inference_products(const std::vector<ConvLayer>& layers, const Algorithm& a) {
  double sum = 0;
  for (const auto& l : layers) {
    if (a.bf16) {
      sum += l.macs * (l.bf16_inference == ConvLayer::winograd    ? a.tile_share
                       : l.bf16_inference == ConvLayer::upsampled ? 0.25
                                                                   : 1);
    } else {
      sum += l.macs * (a.fp32_takes(l) ? a.tile_share : 1);
    }
  }
  return sum;
}

// The training forward, or the input gradient (the same convolutions transposed; without the first
// layer's when its input takes no gradient).
inline double training_products(const std::vector<ConvLayer>& layers, const Algorithm& a, bool first_layer = true) {
  double sum = 0;
  for (size_t i = first_layer ? 0 : 1; i < layers.size(); ++i) {
    const ConvLayer& l = layers[i];
    sum += l.macs * ((a.bf16 ? l.bf16_trained : a.fp32_takes(l)) ? a.tile_share : 1);
  }
  return sum;
}

inline double weight_gradient_products(const std::vector<ConvLayer>& layers, const Algorithm& a) {
  Algorithm w = a;
  if (a.bf16) w.tile_share = 16.0 / 36;  // F(2x2, 3x3)'s transposed transforms
  return training_products(layers, w);
}

}  // namespace bench
