#pragma once
// A latent NeRF: a hash-grid field (Instant-NGP's architecture) whose "colour" is a C-channel normalised
// latent. A point's grid features go through a density MLP (features → hidden → 1 + geo), whose first
// output is the log-density, σ = exp(min(raw, 11)), and all of whose outputs go through a latent MLP
// (→ hidden → hidden → C) and a sigmoid, so that latents stay in the normalised range [0, 1]. The latent
// does not depend on the viewing direction, like the latent Gaussian field's default (SH degree 0).
//
// On disk (field.safetensors): the grid table and the MLPs' weights as float32 tensors, and the spec
// (architecture, sampling, scene bounds) as JSON in the metadata.
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <ATen/Tensor.h>
#include <nlohmann/json.hpp>

#include "lrf/nerf/hash_encoding.h"
#include "lrf/nerf/mlp.h"
#include "lrf/nerf/scene_bounds.h"

namespace lrf::nerf {

// Above this raw output the density stops growing (and passes no gradient): exp(11) ≈ 6·10⁴ per unit
// length is opaque within any interval the sampler makes, and the cap keeps exp() finite.
constexpr float kMaxLogDensity = 11.0f;

struct NerfSpec {
  HashGridSpec grid;
  int hidden = 64;        // width of both MLPs
  int geo_features = 15;  // density MLP outputs besides the log-density
  int channels = 32;      // latent channels
  int coarse_samples = 32, fine_samples = 32;  // per ray
  SceneBounds bounds;
  std::vector<float> background;  // per channel, what a ray that passes through everything sees

  int samples() const { return coarse_samples + fine_samples; }
  // Throws lrf::Error naming the setting when one is out of range.
  void check() const;
  nlohmann::json to_json() const;
  static NerfSpec from_json(const nlohmann::json& j, const std::string& path);
};

struct NerfField {
  NerfSpec spec;
  at::Tensor table;  // [grid.total_entries(), grid.features] float32
  Mlp density;       // grid.output_dim() → hidden → 1 + geo_features
  Mlp latent;        // 1 + geo_features → hidden → hidden → channels

  // Grid features uniform in ±1e-4 (Instant-NGP), MLPs as nn.Linear; all from `seed`.
  static NerfField create(const NerfSpec& spec, uint64_t seed);
  // The same layout filled with zeros (gradients, optimiser moments).
  NerfField zeros_like() const;
  int64_t parameter_count() const;
  // Every tensor with a stable name, in a fixed order (file layout, optimiser, checkpoints).
  std::vector<std::pair<std::string, at::Tensor>> named_tensors() const;

  void save(const std::string& path, const std::map<std::string, std::string>& metadata = {}) const;
  // Throws lrf::Error naming the file when it is unreadable, its spec is bad, or a tensor is missing,
  // misshapen, not float32 or not finite.
  static NerfField load(const std::string& path);
};

}  // namespace lrf::nerf
