#include "lrf/splat/gaussians.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <unordered_map>

#include <ATen/ATen.h>
#include <ATen/CPUGeneratorImpl.h>
#include <ATen/Parallel.h>

#include "lrf/core/error.h"

namespace lrf::splat {

std::vector<torch::Tensor*> Gaussians::parameters() {
  return {&means, &log_scales, &quats, &opacity_logits, &sh};
}

std::vector<const torch::Tensor*> Gaussians::parameters() const {
  return {&means, &log_scales, &quats, &opacity_logits, &sh};
}

const std::vector<std::string>& Gaussians::parameter_names() {
  static const std::vector<std::string> names = {"means", "log_scales", "quats", "opacity_logits", "sh"};
  return names;
}

void Gaussians::make_leaves() {
  for (auto* p : parameters()) {
    *p = p->detach().to(torch::kFloat32).contiguous().clone().set_requires_grad(true);
  }
}

void Gaussians::check(const std::string& what) const {
  if (!means.defined() || means.dim() != 2 || means.size(1) != 3) fail(what, "means must be [N, 3]");
  const int64_t n = means.size(0);
  auto rows = [&](const torch::Tensor& t, int64_t cols, const char* name) {
    if (!t.defined() || t.dim() != 2 || t.size(0) != n || t.size(1) != cols)
      fail(what, std::string(name) + " must be [N, " + std::to_string(cols) + "] with N = " +
                     std::to_string(n));
  };
  rows(log_scales, 3, "log_scales");
  rows(quats, 4, "quats");
  rows(opacity_logits, 1, "opacity_logits");
  if (!sh.defined() || sh.dim() != 3 || sh.size(0) != n || sh.size(2) < 1)
    fail(what, "sh must be [N, K, C]");
  if (sh.size(1) != sh_coefficients(max_sh_degree))
    fail(what, "sh has " + std::to_string(sh.size(1)) + " coefficients, SH degree " +
                   std::to_string(max_sh_degree) + " needs " +
                   std::to_string(sh_coefficients(max_sh_degree)));
}

Gaussians Gaussians::clone() const {
  Gaussians g;
  g.max_sh_degree = max_sh_degree;
  auto src = parameters();
  auto dst = g.parameters();
  for (size_t i = 0; i < src.size(); ++i) *dst[i] = src[i]->detach().clone();
  return g;
}

void Gaussians::permute_rows(const torch::Tensor& order) {
  for (auto* p : parameters()) *p = p->detach().index_select(0, order).set_requires_grad(true);
}

torch::Tensor features_to_sh_dc(const torch::Tensor& features) { return (features - 0.5) / kShC0; }
torch::Tensor sh_dc_to_features(const torch::Tensor& dc) { return dc * kShC0 + 0.5; }

namespace {

// Cell key of integer grid coordinates (21 bits each, wrapped; collisions only merge buckets).
inline int64_t cell_key(int64_t x, int64_t y, int64_t z) {
  constexpr int64_t mask = (1 << 21) - 1;
  return ((x & mask) << 42) | ((y & mask) << 21) | (z & mask);
}

}  // namespace

torch::Tensor mean_sq_dist_3nn(const torch::Tensor& xyz_in) {
  auto xyz = xyz_in.detach().to(torch::kFloat64).contiguous();
  const int64_t n = xyz.size(0);
  auto out = torch::zeros({n}, torch::kFloat32);
  if (n < 2) return out.fill_(1e-2f);  // a lone point gets an arbitrary small size
  const double* p = xyz.data_ptr<double>();
  // Cell size so that cells hold about 2 points on average over the bounding box.
  double lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::numeric_limits<double>::infinity();
    hi[a] = -lo[a];
  }
  for (int64_t i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], p[3 * i + a]);
      hi[a] = std::max(hi[a], p[3 * i + a]);
    }
  double volume = 1;
  int flat_axes = 0;
  for (int a = 0; a < 3; ++a) {
    double ext = hi[a] - lo[a];
    if (ext > 0) volume *= ext; else ++flat_axes;
  }
  const double diag = std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                (hi[2] - lo[2]) * (hi[2] - lo[2]));
  if (diag <= 0) return out.fill_(1e-7f);  // all points coincide
  double cell = flat_axes == 0 ? std::cbrt(2.0 * volume / double(n)) : diag / std::cbrt(double(n));
  cell = std::max(cell, diag * 1e-6);

  std::unordered_map<int64_t, std::vector<int64_t>> grid;
  grid.reserve(static_cast<size_t>(n));
  std::vector<std::array<int64_t, 3>> coord(static_cast<size_t>(n));
  for (int64_t i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) coord[i][a] = static_cast<int64_t>(std::floor((p[3 * i + a] - lo[a]) / cell));
    grid[cell_key(coord[i][0], coord[i][1], coord[i][2])].push_back(i);
  }
  const int64_t want = std::min<int64_t>(3, n - 1);
  float* o = out.data_ptr<float>();
  at::parallel_for(0, n, 256, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) {
      std::array<double, 3> best = {std::numeric_limits<double>::infinity(),
                                    std::numeric_limits<double>::infinity(),
                                    std::numeric_limits<double>::infinity()};
      // Search growing shells of cells; after shell r every point closer than r * cell was seen.
      for (int64_t r = 0;; ++r) {
        for (int64_t dx = -r; dx <= r; ++dx)
          for (int64_t dy = -r; dy <= r; ++dy)
            for (int64_t dz = -r; dz <= r; ++dz) {
              if (std::max({std::llabs(dx), std::llabs(dy), std::llabs(dz)}) != r) continue;
              auto it = grid.find(cell_key(coord[i][0] + dx, coord[i][1] + dy, coord[i][2] + dz));
              if (it == grid.end()) continue;
              for (int64_t j : it->second) {
                if (j == i) continue;
                double d2 = 0;
                for (int a = 0; a < 3; ++a) {
                  double d = p[3 * j + a] - p[3 * i + a];
                  d2 += d * d;
                }
                if (d2 < best[2]) {
                  best[2] = d2;
                  std::sort(best.begin(), best.end());
                }
              }
            }
        const double reach = double(r) * cell;
        if (best[want - 1] <= reach * reach) break;
        if (reach > 2 * diag + cell) break;  // everything has been visited
      }
      double sum = 0;
      for (int64_t k = 0; k < want; ++k) sum += best[k];
      o[i] = static_cast<float>(std::max(sum / double(want), 1e-7));
    }
  });
  return out;
}

Gaussians gaussians_from_points(const torch::Tensor& xyz, const torch::Tensor& features, int max_sh_degree) {
  if (xyz.dim() != 2 || xyz.size(1) != 3) fail("gaussians_from_points: xyz must be [N, 3]");
  if (features.dim() != 2 || features.size(0) != xyz.size(0))
    fail("gaussians_from_points: features must be [N, C] with the same N as xyz");
  if (max_sh_degree < 0 || max_sh_degree > 3) fail("SH degree must be 0..3");
  const int64_t n = xyz.size(0);
  const int64_t c = features.size(1);
  Gaussians g;
  g.max_sh_degree = max_sh_degree;
  g.means = xyz.to(torch::kFloat32).clone();
  g.log_scales = torch::log(torch::sqrt(mean_sq_dist_3nn(xyz))).unsqueeze(1).repeat({1, 3});
  g.quats = torch::zeros({n, 4}, torch::kFloat32);
  g.quats.select(1, 0).fill_(1.0f);
  // logit(0.1)
  g.opacity_logits = torch::full({n, 1}, std::log(0.1 / 0.9), torch::kFloat32);
  g.sh = torch::zeros({n, sh_coefficients(max_sh_degree), c}, torch::kFloat32);
  g.sh.select(1, 0).copy_(features_to_sh_dc(features.to(torch::kFloat32)));
  g.make_leaves();
  return g;
}

torch::Tensor random_points(int64_t count, const Eigen::Vector3d& centre, double half_size, uint64_t seed) {
  auto gen = at::make_generator<at::CPUGeneratorImpl>(seed);
  auto u = at::rand({count, 3}, gen, torch::kFloat64) * 2.0 - 1.0;
  auto c = torch::tensor({centre.x(), centre.y(), centre.z()}, torch::kFloat64);
  return (u * half_size + c).to(torch::kFloat32);
}

}  // namespace lrf::splat
