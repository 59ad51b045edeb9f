#pragma once
// The NeRF's small fully connected networks: Linear → ReLU → … → Linear (no activation on the output),
// float32, with an explicit backward pass. Each layer is one matrix product over the whole batch of
// samples (BLAS), so there is nothing per sample for autograd to record.
#include <cstdint>
#include <vector>

#include <ATen/Tensor.h>

namespace lrf::nerf {

struct Mlp {
  std::vector<at::Tensor> weights;  // [out, in] per layer
  std::vector<at::Tensor> biases;   // [out] per layer

  // Layer sizes {in, hidden…, out}; weights and biases uniform in ±1/√in (PyTorch's nn.Linear default).
  static Mlp create(const std::vector<int>& sizes, uint64_t seed);
  // Zero tensors of the same shapes (for gradients and optimiser moments).
  Mlp zeros_like() const;
  int layers() const { return static_cast<int>(weights.size()); }
  int input_dim() const;
  int output_dim() const;
  int64_t parameter_count() const;

  // y = f(x) for x [n, in]; `inputs` (when given) keeps each layer's input for backward.
  at::Tensor forward(const at::Tensor& x, std::vector<at::Tensor>* inputs = nullptr) const;
  // Given ∂L/∂y [n, out] and the inputs kept by forward, adds ∂L/∂weights and ∂L/∂biases into `grads`
  // and returns ∂L/∂x [n, in].
  at::Tensor backward(const std::vector<at::Tensor>& inputs, const at::Tensor& d_y, Mlp* grads) const;
};

}  // namespace lrf::nerf
