#pragma once
// Stage II normalises each latent channel to [0, 1] with the min and max over the training views'
// latents (the paper's code does this "to stabilise radiance field optimisation"); test views use the
// same range, and rendered latents are clamped to [0, 1] and mapped back before decoding.
#include <vector>

#include <nlohmann/json.hpp>
#include <torch/types.h>

namespace lrf {

struct LatentRange {
  std::vector<float> min, max;  // per channel

  int channels() const { return static_cast<int>(min.size()); }
  // z [C, h, w] (or [B, C, h, w]) -> (z - min) / (max - min); constant channels map to 0.
  torch::Tensor normalize(const torch::Tensor& z) const;
  // Clamps to [0, 1], then maps back to raw latent values.
  torch::Tensor denormalize(const torch::Tensor& zn) const;
  nlohmann::json to_json() const;
  static LatentRange from_json(const nlohmann::json& j, const std::string& path);
};

// Range over all training latents, each [C, h, w] with the same C.
LatentRange compute_latent_range(const std::vector<torch::Tensor>& latents);

}  // namespace lrf
