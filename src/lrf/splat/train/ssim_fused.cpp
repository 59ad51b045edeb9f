#include "lrf/splat/train/ssim_fused.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <ATen/Parallel.h>
#include <torch/autograd.h>

namespace lrf::splat {
namespace {

constexpr int kRadius = 5;
constexpr float kC1 = 0.01f * 0.01f, kC2 = 0.03f * 0.03f;

struct Window {
  float w[2 * kRadius + 1];
  Window() {
    double sum = 0, v[2 * kRadius + 1];
    for (int i = -kRadius; i <= kRadius; ++i) sum += (v[i + kRadius] = std::exp(-double(i * i) / (2 * 1.5 * 1.5)));
    for (int i = 0; i <= 2 * kRadius; ++i) w[i] = float(v[i] / sum);
  }
};
const Window& window() {
  static const Window w;
  return w;
}

// One thread's scratch for blurring h x w planes. Rows are padded to a multiple of 8 floats so that the
// loops over x have no scalar tail: at latent size (w = 63) the tail of 7 took as long as the 7 vector
// steps before it. The padding columns hold finite values that never reach an output.
struct BlurScratch {
  int h, w, wp;
  std::vector<float> tmp, row, acc;
  BlurScratch(int height, int width)
      : h(height), w(width), wp((width + 7) / 8 * 8), tmp(static_cast<size_t>(height) * wp),
        row(wp + 2 * kRadius, 0.f), acc(wp) {}
};

// Zero-padded separable blur of one h x w plane (symmetric window: also its own adjoint). Each pass adds
// the taps in the same order for every pixel, out-of-image taps as exact zeros, so that the loops over x
// vectorise. Also compiled for AVX2 and picked at load time where the CPU has it: 8 lanes instead of
// SSE2's 4, the same multiplies and adds per element (no FMA), so the same bits.
__attribute__((target_clones("avx2", "default"))) void blur_plane(const float* in, float* __restrict out,
                                                                 BlurScratch& scratch) {
  const float* k = window().w;
  const int h = scratch.h, w = scratch.w, wp = scratch.wp;
  float* __restrict row = scratch.row.data();  // zeros outside [kRadius, kRadius + w), set once
  float* __restrict tmp = scratch.tmp.data();
  float* __restrict acc = scratch.acc.data();
  for (int y = 0; y < h; ++y) {
    std::copy(in + static_cast<int64_t>(y) * w, in + static_cast<int64_t>(y + 1) * w, row + kRadius);
    float* __restrict t = tmp + static_cast<int64_t>(y) * wp;
    for (int x = 0; x < wp; ++x) t[x] = 0;
    for (int d = 0; d <= 2 * kRadius; ++d) {
      const float kd = k[d];
      const float* __restrict src = row + d;
      for (int x = 0; x < wp; ++x) t[x] += kd * src[x];
    }
  }
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < wp; ++x) acc[x] = 0;
    const int lo = std::max(-kRadius, -y), hi = std::min(kRadius, h - 1 - y);
    for (int d = lo; d <= hi; ++d) {
      const float kd = k[d + kRadius];
      const float* __restrict t = tmp + static_cast<int64_t>(y + d) * wp;
      for (int x = 0; x < wp; ++x) acc[x] += kd * t[x];
    }
    std::copy(acc, acc + w, out + static_cast<int64_t>(y) * w);
  }
}

class FusedSsim : public torch::autograd::Function<FusedSsim> {
 public:
  static torch::Tensor forward(torch::autograd::AutogradContext* ctx, const torch::Tensor& a_in,
                               const torch::Tensor& b_in) {
    auto a = a_in.contiguous(), b = b_in.contiguous();
    const int h = static_cast<int>(a.size(-2)), w = static_cast<int>(a.size(-1));
    const int64_t planes = a.numel() / (int64_t(h) * w), plane = int64_t(h) * w;
    // stats: [planes, 5, h, w] = blurred a, b, a^2, b^2, ab.
    auto stats = torch::empty({planes, 5, h, w}, torch::kFloat32);
    auto sums = torch::zeros({planes}, torch::kFloat64);
    const float* pa = a.data_ptr<float>();
    const float* pb = b.data_ptr<float>();
    float* ps = stats.data_ptr<float>();
    double* psum = sums.data_ptr<double>();
    at::parallel_for(0, planes, 1, [&](int64_t begin, int64_t end) {
      std::vector<float> src(plane);
      BlurScratch scratch(h, w);
      for (int64_t p = begin; p < end; ++p) {
        const float* x = pa + p * plane;
        const float* y = pb + p * plane;
        float* s = ps + p * 5 * plane;
        blur_plane(x, s, scratch);
        blur_plane(y, s + plane, scratch);
        for (int64_t i = 0; i < plane; ++i) src[i] = x[i] * x[i];
        blur_plane(src.data(), s + 2 * plane, scratch);
        for (int64_t i = 0; i < plane; ++i) src[i] = y[i] * y[i];
        blur_plane(src.data(), s + 3 * plane, scratch);
        for (int64_t i = 0; i < plane; ++i) src[i] = x[i] * y[i];
        blur_plane(src.data(), s + 4 * plane, scratch);
        double total = 0;
        for (int64_t i = 0; i < plane; ++i) {
          const float ma = s[i], mb = s[plane + i];
          const float a1 = 2 * ma * mb + kC1, a2 = 2 * (s[4 * plane + i] - ma * mb) + kC2;
          const float b1 = ma * ma + mb * mb + kC1;
          const float b2 = (s[2 * plane + i] - ma * ma) + (s[3 * plane + i] - mb * mb) + kC2;
          total += double(a1 * a2 / (b1 * b2));
        }
        psum[p] = total;
      }
    });
    ctx->save_for_backward({a, b, stats});
    return torch::tensor(sums.sum().item<double>() / double(a.numel()), torch::kFloat32);
  }

  static torch::autograd::variable_list backward(torch::autograd::AutogradContext* ctx,
                                                 torch::autograd::variable_list grad_out) {
    auto saved = ctx->get_saved_variables();
    auto a = saved[0], b = saved[1], stats = saved[2];
    const int h = static_cast<int>(a.size(-2)), w = static_cast<int>(a.size(-1));
    const int64_t plane = int64_t(h) * w, planes = a.numel() / plane;
    const float scale = grad_out[0].item<float>() / float(a.numel());
    auto grad = torch::empty_like(a);
    const float* pa = a.data_ptr<float>();
    const float* pb = b.data_ptr<float>();
    const float* ps = stats.data_ptr<float>();
    float* pg = grad.data_ptr<float>();
    at::parallel_for(0, planes, 1, [&](int64_t begin, int64_t end) {
      std::vector<float> d_ma(plane), d_saa(plane), d_sab(plane), blurred(plane);
      BlurScratch scratch(h, w);
      for (int64_t p = begin; p < end; ++p) {
        const float* s = ps + p * 5 * plane;
        // dS/d(blurred a), dS/d(blurred a^2), dS/d(blurred ab) per pixel.
        for (int64_t i = 0; i < plane; ++i) {
          const float ma = s[i], mb = s[plane + i];
          const float a1 = 2 * ma * mb + kC1, a2 = 2 * (s[4 * plane + i] - ma * mb) + kC2;
          const float b1 = ma * ma + mb * mb + kC1;
          const float b2 = (s[2 * plane + i] - ma * ma) + (s[3 * plane + i] - mb * mb) + kC2;
          const float ssim = a1 * a2 / (b1 * b2);
          d_ma[i] = scale * ssim * (2 * mb / a1 - 2 * mb / a2 - 2 * ma / b1 + 2 * ma / b2);
          d_saa[i] = scale * ssim * (-1 / b2);
          d_sab[i] = scale * ssim * (2 / a2);
        }
        const float* x = pa + p * plane;
        const float* y = pb + p * plane;
        float* g = pg + p * plane;
        blur_plane(d_ma.data(), g, scratch);
        blur_plane(d_saa.data(), blurred.data(), scratch);
        for (int64_t i = 0; i < plane; ++i) g[i] += 2 * x[i] * blurred[i];
        blur_plane(d_sab.data(), blurred.data(), scratch);
        for (int64_t i = 0; i < plane; ++i) g[i] += y[i] * blurred[i];
      }
    });
    return {grad, torch::Tensor()};
  }
};

}  // namespace

torch::Tensor fused_ssim(const torch::Tensor& a, const torch::Tensor& b) {
  TORCH_CHECK(a.sizes() == b.sizes() && a.dim() >= 3, "fused_ssim: a and b must be [.., C, H, W] of one shape");
  TORCH_CHECK(a.scalar_type() == torch::kFloat32 && b.scalar_type() == torch::kFloat32, "fused_ssim: float32 only");
  return FusedSsim::apply(a, b.detach());
}

}  // namespace lrf::splat
