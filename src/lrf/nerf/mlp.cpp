#include "lrf/nerf/mlp.h"

#include <cmath>

#include <ATen/ATen.h>
#include <ATen/CPUGeneratorImpl.h>

#include "lrf/core/error.h"

namespace lrf::nerf {

Mlp Mlp::create(const std::vector<int>& sizes, uint64_t seed) {
  if (sizes.size() < 2) fail("an MLP needs at least an input and an output size");
  for (int s : sizes)
    if (s < 1) fail("MLP layer sizes must be positive");
  auto gen = at::make_generator<at::CPUGeneratorImpl>(seed);
  Mlp m;
  for (size_t k = 0; k + 1 < sizes.size(); ++k) {
    const double bound = 1.0 / std::sqrt(double(sizes[k]));
    m.weights.push_back(at::empty({sizes[k + 1], sizes[k]}, at::kFloat).uniform_(-bound, bound, gen));
    m.biases.push_back(at::empty({sizes[k + 1]}, at::kFloat).uniform_(-bound, bound, gen));
  }
  return m;
}

Mlp Mlp::zeros_like() const {
  Mlp z;
  for (const auto& w : weights) z.weights.push_back(at::zeros_like(w));
  for (const auto& b : biases) z.biases.push_back(at::zeros_like(b));
  return z;
}

int Mlp::input_dim() const { return weights.empty() ? 0 : static_cast<int>(weights.front().size(1)); }
int Mlp::output_dim() const { return weights.empty() ? 0 : static_cast<int>(weights.back().size(0)); }

int64_t Mlp::parameter_count() const {
  int64_t n = 0;
  for (size_t k = 0; k < weights.size(); ++k) n += weights[k].numel() + biases[k].numel();
  return n;
}

at::Tensor Mlp::forward(const at::Tensor& x, std::vector<at::Tensor>* inputs) const {
  if (inputs) inputs->clear();
  at::Tensor h = x;
  for (size_t k = 0; k < weights.size(); ++k) {
    if (inputs) inputs->push_back(h);
    h = at::addmm(biases[k], h, weights[k].t());
    if (k + 1 < weights.size()) h.clamp_min_(0.0);
  }
  return h;
}

at::Tensor Mlp::backward(const std::vector<at::Tensor>& inputs, const at::Tensor& d_y, Mlp* grads) const {
  at::Tensor d = d_y;  // ∂L/∂(layer k's pre-activation output)
  for (size_t k = weights.size(); k-- > 0;) {
    grads->weights[k].addmm_(d.t(), inputs[k]);
    grads->biases[k].add_(d.sum(0));
    at::Tensor d_in = at::mm(d, weights[k]);
    // The input of layer k > 0 is a ReLU's output: its gradient passes where that output is positive.
    if (k > 0) d_in.mul_(inputs[k].gt(0));
    d = d_in;
  }
  return d;
}

}  // namespace lrf::nerf
