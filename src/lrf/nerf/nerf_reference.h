#pragma once
// A deliberately plain float64 latent NeRF renderer for the tests: the contraction, the grid lookup (the
// spatial hash written out again), the MLPs and the compositing as direct loops over one ray at a time,
// with T_i as a running product of (1 − α). The fast kernels are compared with it, and finite differences
// of it check their gradients. Slow: tiny fields only.
#include <string>
#include <utility>
#include <vector>

#include <ATen/Tensor.h>

#include "lrf/nerf/nerf_field.h"
#include "lrf/nerf/nerf_render.h"

namespace lrf::nerf {

struct ReferenceField {
  NerfSpec spec;
  // Every parameter in float64, named and laid out as NerfField::named_tensors() (row-major).
  std::vector<std::pair<std::string, std::vector<double>>> tensors;

  static ReferenceField from(const NerfField& field);
  std::vector<double>& tensor(const std::string& name);
  const std::vector<double>& tensor(const std::string& name) const;
};

// The hash encoding of one point in grid coordinates [0, 1]³ (level-major, as hash_encode_forward).
std::vector<double> reference_encode(const ReferenceField& field, const double point[3]);

// The latent seen along one ray at the sorted samples s[0..n).
std::vector<double> reference_render_ray(const ReferenceField& field, const double origin[3],
                                         const double direction[3], const float* s, int n);

// Volume rendering alone: out[c] = Σ_i T_i α_i values[i][c] + T_n background[c], with T as a product.
std::vector<double> reference_composite(const std::vector<double>& sigma, const std::vector<double>& delta,
                                        const std::vector<std::vector<double>>& values,
                                        const std::vector<double>& background);

// The mean squared error over rays and channels against targets [rays, C], at samples s [rays, S].
double reference_loss(const ReferenceField& field, const Rays& rays, const at::Tensor& s, const at::Tensor& targets);

}  // namespace lrf::nerf
