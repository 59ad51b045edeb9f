#include "lrf/autoencoder/conv/winograd_f32.h"

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <string>

#include <ATen/ATen.h>
#include <ATen/Parallel.h>
#include <torch/autograd.h>

#include "lrf/autoencoder/conv/conv_destination.h"
#include "lrf/autoencoder/conv/relu_mask.h"
#include "lrf/autoencoder/conv/winograd_f32_kernels.h"
#include "lrf/autoencoder/conv/winograd_weight_gradient.h"
#include "lrf/core/cpu_features.h"
#include "lrf/core/error.h"

namespace lrf {
namespace {

using winograd_f32::Geometry;
using winograd_f32::Kernels;
using winograd_f32::kTilesPerUnit;

// The kernels of the widest vectors simd_level() allows, or null.
const Kernels* kernels_now() {
#if defined(__x86_64__)
  if (!winograd_f32_enabled()) return nullptr;
  if (simd_level() >= SimdLevel::avx512) return &winograd_f32::avx512_kernels();
  return &winograd_f32::avx2_kernels();
#else
  return nullptr;
#endif
}

// G of F(m x m, 3x3): U = G g Gᵀ (rows: the m + 2 points).
constexpr double kG2[4][3] = {{1, 0, 0}, {0.5, 0.5, 0.5}, {0.5, -0.5, 0.5}, {0, 0, 1}};
constexpr double kG4[6][3] = {{1.0 / 4, 0, 0},           {-1.0 / 6, -1.0 / 6, -1.0 / 6}, {-1.0 / 6, 1.0 / 6, -1.0 / 6},
                              {1.0 / 24, 1.0 / 12, 1.0 / 6}, {1.0 / 24, -1.0 / 12, 1.0 / 6}, {0, 0, 1}};

constexpr double kG6[8][3] = {{1, 0, 0},
                              {-2.0 / 9, -2.0 / 9, -2.0 / 9},
                              {-2.0 / 9, 2.0 / 9, -2.0 / 9},
                              {1.0 / 90, 1.0 / 45, 2.0 / 45},
                              {1.0 / 90, -1.0 / 45, 2.0 / 45},
                              {32.0 / 45, 16.0 / 45, 8.0 / 45},
                              {32.0 / 45, -16.0 / 45, 8.0 / 45},
                              {0, 0, 1}};

double g_entry(int tile, int r, int c) { return tile == 6 ? kG6[r][c] : tile == 4 ? kG4[r][c] : kG2[r][c]; }

std::string shape_of(const at::Tensor& t) { return c10::str(t.sizes()); }

Geometry geometry(int64_t n, int64_t h, int64_t w, int64_t inputs, int64_t outputs, bool upsampled, int tile) {
  const int64_t out_h = upsampled ? 2 * h : h, out_w = upsampled ? 2 * w : w;
  Geometry g{n, h, w, out_h, out_w, inputs, outputs, upsampled, tile, (out_h + tile - 1) / tile,
             (out_w + tile - 1) / tile, 0};
  g.units_per_row = (g.tiles_x + kTilesPerUnit - 1) / kTilesPerUnit;
  return g;
}

void check_tile(int tile) {
  if (tile != 2 && tile != 4 && tile != 6) {
    fail("WinogradF32Conv3x3: the tile side must be 2, 4 or 6, got " + std::to_string(tile));
  }
}

}  // namespace

bool WinogradF32Conv3x3::runs(int64_t outputs, int64_t inputs) {
  const Kernels* k = kernels_now();
  return k && outputs > 0 && inputs > 0 && outputs % k->lanes == 0 && inputs % k->lanes == 0;
}

int WinogradF32Conv3x3::chosen_tile() { return winograd_f32_tile(); }

WinogradF32Conv3x3::WinogradF32Conv3x3(const at::Tensor& weight, const at::Tensor& bias, bool upsampled_input,
                                       int tile)
    : upsampled_(upsampled_input), tile_(tile) {
  check_tile(tile);
  if (weight.dim() != 4 || weight.size(2) != 3 || weight.size(3) != 3) {
    fail("WinogradF32Conv3x3: weight must be [O, I, 3, 3], got " + shape_of(weight));
  }
  outputs_ = weight.size(0), inputs_ = weight.size(1);
  const int side = tile + 2;
  // U[p = side·r + c][i][o] = (G g Gᵀ)[r][c] in float64, rounded once.
  const at::Tensor w = weight.detach().to(at::kDouble).permute({1, 2, 3, 0}).contiguous();  // [I, 3, 3, O]
  const double* src = w.data_ptr<double>();
  kernels_.assign(static_cast<size_t>(side * side * inputs_ * outputs_), 0.0f);
  float* dst = kernels_.data();
  const int64_t outputs = outputs_, inputs = inputs_;
  at::parallel_for(0, inputs, 4, [&](int64_t i0, int64_t i1) {
    std::vector<double> gk(static_cast<size_t>(side * 3 * outputs));  // G g: [row][kernel column][O]
    for (int64_t i = i0; i < i1; ++i) {
      const double* k = src + i * 9 * outputs;  // k[(3·row + column)·O + o]
      for (int r = 0; r < side; ++r)
        for (int c = 0; c < 3; ++c)
          for (int64_t o = 0; o < outputs; ++o)
            gk[(r * 3 + c) * outputs + o] = g_entry(tile, r, 0) * k[c * outputs + o] +
                                            g_entry(tile, r, 1) * k[(3 + c) * outputs + o] +
                                            g_entry(tile, r, 2) * k[(6 + c) * outputs + o];
      for (int r = 0; r < side; ++r)
        for (int c = 0; c < side; ++c) {
          float* out = dst + ((r * side + c) * inputs + i) * outputs;
          const double* g0 = gk.data() + r * 3 * outputs;
          for (int64_t o = 0; o < outputs; ++o)
            out[o] = static_cast<float>(g0[o] * g_entry(tile, c, 0) + g0[outputs + o] * g_entry(tile, c, 1) +
                                        g0[2 * outputs + o] * g_entry(tile, c, 2));
        }
    }
  });
  bias_ = conv_bias("WinogradF32Conv3x3", bias, outputs_);
}

at::Tensor WinogradF32Conv3x3::forward(const at::Tensor& input, bool relu, const at::Tensor& residual) const {
  if (input.dim() != 4 || input.size(1) != inputs_ || input.scalar_type() != at::kFloat) {
    fail("WinogradF32Conv3x3: input must be float32 [N, " + std::to_string(inputs_) + ", H, W], got " +
         shape_of(input));
  }
  if (!runs(outputs_, inputs_)) {
    fail("WinogradF32Conv3x3: not run here (the CPU has no AVX2 with FMA, LRF_CPU_ISA or LRF_WINOGRAD=0 switched it "
         "off, or the channel counts are not multiples of the vector lanes)");
  }
  const at::Tensor x = input.contiguous(at::MemoryFormat::ChannelsLast);
  const Geometry g = geometry(x.size(0), x.size(2), x.size(3), inputs_, outputs_, upsampled_, tile_);
  at::Tensor out = conv_destination("WinogradF32Conv3x3", x, residual, {g.n, outputs_, g.out_h, g.out_w});
  if (x.numel() == 0) return out;
  const Kernels& k = *kernels_now();
  const float* in = x.data_ptr<float>();
  float* dst = out.data_ptr<float>();
  const float* res = residual.defined() ? dst : nullptr;
  at::parallel_for(0, g.units(), 1, [&](int64_t begin, int64_t end) {
    k.forward(g, in, kernels_.data(), bias_.data(), relu, res, dst, begin, end);
  });
  return out;
}

ConvParameterGradients winograd_f32_weight_gradient(const at::Tensor& input, const at::Tensor& grad_output, int tile) {
  check_tile(tile);
  if (input.dim() != 4 || grad_output.dim() != 4 || input.size(0) != grad_output.size(0) ||
      input.size(2) != grad_output.size(2) || input.size(3) != grad_output.size(3) ||
      input.scalar_type() != at::kFloat || grad_output.scalar_type() != at::kFloat) {
    fail("winograd_f32_weight_gradient: float32 input [N, I, H, W] and grad_output [N, O, H, W] of one size expected, "
         "got " + shape_of(input) + " and " + shape_of(grad_output));
  }
  const int64_t inputs = input.size(1), outputs = grad_output.size(1);
  if (!WinogradF32Conv3x3::runs(outputs, inputs)) fail("winograd_f32_weight_gradient: not run here for these channels");
  const at::Tensor x = input.contiguous(at::MemoryFormat::ChannelsLast);
  const at::Tensor dy = grad_output.contiguous(at::MemoryFormat::ChannelsLast);
  const Geometry g = geometry(x.size(0), x.size(2), x.size(3), inputs, outputs, false, tile);
  const int side = tile + 2, positions = side * side;
  const int64_t per_position = outputs * inputs;
  // Contiguous shares of the units, one per thread, each summed into its own buffer; the buffers are added
  // in share order, so the same inputs give the same bits at a given thread count.
  const int64_t units = g.units();
  const int64_t shares = std::max<int64_t>(1, std::min<int64_t>(at::get_num_threads(), units));
  const int64_t per_share = (units + shares - 1) / shares;
  at::Tensor partial = at::zeros({shares, positions, outputs, inputs}, at::kFloat);
  const Kernels& k = *kernels_now();
  const float* in = x.data_ptr<float>();
  const float* go = dy.data_ptr<float>();
  float* sums = partial.data_ptr<float>();
  at::parallel_for(0, shares, 1, [&](int64_t s0, int64_t s1) {
    for (int64_t s = s0; s < s1; ++s) {
      const int64_t begin = s * per_share, end = std::min(units, begin + per_share);
      if (begin < end) k.weight_gradient(g, in, go, sums + s * positions * per_position, begin, end);
    }
  });
  at::Tensor du = partial[0];
  for (int64_t s = 1; s < shares; ++s) du = du + partial[s];
  // dW = Gᵀ dU G per (o, i), in float64.
  const at::Tensor du64 = du.to(at::kDouble).reshape({side, side, outputs, inputs});
  at::Tensor gm = at::empty({side, 3}, at::kDouble);
  for (int r = 0; r < side; ++r)
    for (int c = 0; c < 3; ++c) gm[r][c] = g_entry(tile, r, c);
  // dW[o][i][a][b] = Σ_{r,c} G[r][a] dU[r][c][o][i] G[c][b]
  const at::Tensor weight = at::einsum("ra,rcoi,cb->oiab", {gm, du64, gm}).to(at::kFloat).contiguous();
  const at::Tensor bias = dy.sum({0, 2, 3}).to(at::kFloat);
  return {weight, bias};
}

bool winograd_f32_trains(const at::Tensor& input, const at::Tensor& weight) {
  return input.scalar_type() == at::kFloat && weight.scalar_type() == at::kFloat && weight.dim() == 4 &&
         weight.size(2) == 3 && weight.size(3) == 3 && input.dim() == 4 &&
         WinogradF32Conv3x3::runs(weight.size(0), weight.size(1));
}

namespace {

using torch::autograd::AutogradContext;
using torch::autograd::variable_list;

class WinogradF32Function : public torch::autograd::Function<WinogradF32Function> {
 public:
  // `bias`, `residual`: tensors of no elements for none (autograd::Function takes no undefined inputs).
  static at::Tensor forward(AutogradContext* ctx, const at::Tensor& input, const at::Tensor& weight,
                            const at::Tensor& bias, const at::Tensor& residual, bool relu) {
    const at::Tensor x = input.contiguous(at::MemoryFormat::ChannelsLast);
    // The convolution adds itself into a copy of the residual, which becomes the output: one pass for the
    // convolution, its residual and its ReLU.
    const at::Tensor into = residual.numel() > 0 ? residual.to(at::kFloat).clone(at::MemoryFormat::ChannelsLast)
                                                 : at::Tensor();
    const at::Tensor y = WinogradF32Conv3x3(weight, bias.numel() > 0 ? bias : at::Tensor()).forward(x, relu, into);
    ctx->saved_data["has_bias"] = bias.numel() > 0;
    ctx->saved_data["relu"] = relu;
    // The output is kept only for the ReLU's mask.
    ctx->save_for_backward({x, weight, relu ? y : at::Tensor()});
    return y;
  }

  static variable_list backward(AutogradContext* ctx, variable_list grad_outputs) {
    const auto saved = ctx->get_saved_variables();
    const at::Tensor &x = saved[0], &weight = saved[1];
    at::Tensor g = grad_outputs[0].to(at::kFloat).contiguous(at::MemoryFormat::ChannelsLast);
    if (ctx->saved_data["relu"].toBool()) g = relu_masked<int32_t>(g, saved[2]);
    at::Tensor grad_input, grad_weight, grad_bias, grad_residual;
    if (ctx->needs_input_grad(0)) {
      // The input's gradient: the output's gradient convolved with the kernels transposed ([I, O]) and flipped.
      const at::Tensor flipped = weight.detach().permute({1, 0, 2, 3}).flip({2, 3});
      grad_input = WinogradF32Conv3x3(flipped, at::Tensor()).forward(g, false);
    }
    if (ctx->needs_input_grad(1) || ctx->needs_input_grad(2)) {
      ConvParameterGradients p = winograd_f32_weight_gradient(x, g);
      if (ctx->needs_input_grad(1)) grad_weight = p.weight.contiguous(weight.suggest_memory_format());
      if (ctx->needs_input_grad(2) && ctx->saved_data["has_bias"].toBool()) grad_bias = p.bias;
    }
    // The placeholder of a missing residual takes no gradient, so this asks for a real one only.
    if (ctx->needs_input_grad(3)) grad_residual = g;
    return {grad_input, grad_weight, grad_bias, grad_residual, at::Tensor()};
  }
};

}  // namespace

at::Tensor winograd_f32_conv3x3_trained(const at::Tensor& input, const at::Tensor& weight, const at::Tensor& bias,
                                        const at::Tensor& residual, bool relu) {
  if (!winograd_f32_trains(input, weight)) fail("winograd_f32_conv3x3_trained: this convolution is not run here");
  // A residual of the wrong shape is refused by the convolution's own check (conv_destination.h).
  const at::Tensor b = bias.defined() ? bias : at::empty({0}, weight.options());
  const at::Tensor r = residual.defined() ? residual : at::empty({0}, input.options());
  return WinogradF32Function::apply(input, weight, b, r, relu);
}

}  // namespace lrf
