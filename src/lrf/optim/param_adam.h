#pragma once
// Adam over a list of parameter tensors, for the jobs that train network weights: Stage I and Stage III
// (one half of an autoencoder), the feature field's lift, the refinement's decoder and the latent NeRF (its
// hash grid and MLPs). They must stop and resume to exactly the same result, so the optimizer is a small
// explicit Adam whose whole state (the parameters, both moments, the step) is one safetensors checkpoint;
// everything random in a step is derived from (seed, step), so nothing else has to be saved. (The
// Gaussians have their own sparse, SIMD Adam, which also prunes and grows with the field:
// splat/train/optimizer.h.)
//
// A float32 parameter is updated in one fused pass (moments and parameter together, no temporaries); others
// through tensor operations, the same formula.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <ATen/Tensor.h>

namespace lrf {

struct AdamOptions {
  double lr = 1e-4;
  double beta1 = 0.9, beta2 = 0.999, eps = 1e-8;
};

class ParamAdam {
 public:
  // `lazy` (one flag per parameter, or empty for none): entries of that parameter whose gradient is exactly
  // 0 in a step keep their value and moments, as Instant-NGP updates its hash grid, so that rarely seen
  // cells are not dragged by stale momentum.
  ParamAdam(std::vector<at::Tensor> params, AdamOptions options, std::vector<bool> lazy = {});
  // Clears every parameter's gradient.
  void zero_grad();
  // One update from the parameters' .grad() (parameters without a gradient are skipped).
  void step();
  // One update from gradients computed by hand (one per parameter, same shapes; undefined ones skipped).
  void step(const std::vector<at::Tensor>& grads);
  int64_t steps() const { return steps_; }
  void set_steps(int64_t steps) { steps_ = steps; }
  const std::vector<at::Tensor>& parameters() const { return params_; }
  // The parameters, then both moments: the whole state but the step (for copying it between ranks).
  std::vector<at::Tensor> state_tensors() const;
  void set_lr(double lr) { options_.lr = lr; }
  double lr() const { return options_.lr; }

  // Writes parameters, moments and the step count (plus `metadata`) atomically to `path`.
  void save(const std::string& path, const std::map<std::string, std::string>& metadata) const;
  // Restores everything save() wrote; throws lrf::Error naming `path` if the file does not hold the same
  // number of parameters with the same shapes. Returns the file's metadata.
  std::map<std::string, std::string> load(const std::string& path);

 private:
  std::vector<at::Tensor> params_, m_, v_;
  std::vector<bool> lazy_;
  AdamOptions options_;
  int64_t steps_ = 0;
};

}  // namespace lrf
