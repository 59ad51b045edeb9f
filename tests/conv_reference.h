#pragma once
// Float64 references for the convolution kernels' tests: a plain-loop convolution and the error measures
// the kernels are held to.
#include <algorithm>

#include <torch/torch.h>

namespace lrf_test {

// relu?(conv(x) + bias + residual) in float64 plain loops; x [N, I, H, W], w [O, I, k, k].
inline at::Tensor reference_conv(const at::Tensor& x, const at::Tensor& w, const at::Tensor& b, int stride, int pad,
                          const at::Tensor& residual, bool relu) {
  const at::Tensor xd = x.to(at::kDouble).contiguous(), wd = w.to(at::kDouble).contiguous();
  const int64_t n = x.size(0), ci = x.size(1), h = x.size(2), wi = x.size(3);
  const int64_t co = w.size(0), k = w.size(2);
  const int64_t oh = (h + 2 * pad - k) / stride + 1, ow = (wi + 2 * pad - k) / stride + 1;
  at::Tensor out = torch::zeros({n, co, oh, ow}, at::kDouble);
  auto X = xd.accessor<double, 4>();
  auto W = wd.accessor<double, 4>();
  auto O = out.accessor<double, 4>();
  const at::Tensor rd = residual.defined() ? residual.to(at::kDouble).contiguous() : at::Tensor();
  const at::Tensor bd = b.defined() ? b.to(at::kDouble).contiguous() : at::Tensor();
  for (int64_t s = 0; s < n; ++s)
    for (int64_t o = 0; o < co; ++o)
      for (int64_t y = 0; y < oh; ++y)
        for (int64_t xx = 0; xx < ow; ++xx) {
          double acc = bd.defined() ? bd[o].item<double>() : 0.0;
          for (int64_t c = 0; c < ci; ++c)
            for (int64_t dy = 0; dy < k; ++dy)
              for (int64_t dx = 0; dx < k; ++dx) {
                const int64_t iy = y * stride - pad + dy, ix = xx * stride - pad + dx;
                if (iy < 0 || iy >= h || ix < 0 || ix >= wi) continue;
                acc += X[s][c][iy][ix] * W[o][c][dy][dx];
              }
          if (rd.defined()) acc += rd[s][o][y][xx].item<double>();
          O[s][o][y][xx] = relu ? std::max(acc, 0.0) : acc;
        }
  return out;
}

inline double max_abs(const at::Tensor& a, const at::Tensor& b) {
  return (a.to(at::kDouble) - b.to(at::kDouble)).abs().max().item<double>();
}

inline at::Tensor channels_last(const at::Tensor& t) { return t.contiguous(at::MemoryFormat::ChannelsLast); }

// Error of `got` against `want`: rms relative to want's rms, and largest relative to want's largest.
struct RelativeError {
  double rms, max;
};
inline RelativeError relative_error(const at::Tensor& got, const at::Tensor& want) {
  const at::Tensor e = got.to(at::kDouble) - want.to(at::kDouble);
  return {(e.pow(2).mean().sqrt() / want.to(at::kDouble).pow(2).mean().sqrt()).item<double>(),
          (e.abs().max() / want.abs().max()).item<double>()};
}

}  // namespace lrf_test
