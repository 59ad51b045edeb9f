#pragma once
// Adam over a list of dense parameter tensors, for the jobs that train network weights: Stage I and Stage
// III (one half of an autoencoder), the feature field's lift and the refinement's decoder. They must stop and
// resume to exactly the same result, so the optimizer is a small explicit Adam whose whole state (the
// parameters, both moments, the step) is one safetensors checkpoint; everything random in a step is derived
// from (seed, step), so nothing else has to be saved. (The Gaussians have their own sparse, SIMD Adam:
// splat/train/optimizer.h.)
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
  ParamAdam(std::vector<at::Tensor> params, AdamOptions options);
  // Clears every parameter's gradient.
  void zero_grad();
  // One update from the parameters' .grad() (parameters without a gradient are skipped).
  void step();
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
  AdamOptions options_;
  int64_t steps_ = 0;
};

}  // namespace lrf
