#include "lrf/nerf/nerf_reference.h"

#include <algorithm>
#include <cmath>

#include <ATen/ATen.h>

#include "lrf/core/error.h"

namespace lrf::nerf {
namespace {

// Grid coordinates of a world point: box, max-norm contraction, [−2, 2]³ → [0, 1]³.
void reference_grid_point(const SceneBounds& b, const double world[3], double out[3]) {
  double x[3], norm = 0;
  for (int a = 0; a < 3; ++a) {
    x[a] = (world[a] - b.center[a]) / b.half[a];
    norm = std::max(norm, std::fabs(x[a]));
  }
  const double scale = norm > 1 ? (2 - 1 / norm) / norm : 1.0;
  for (int a = 0; a < 3; ++a) out[a] = std::min(1.0, std::max(0.0, (x[a] * scale + 2) / 4));
}

uint64_t reference_vertex(const HashGridSpec& g, int level, uint64_t i, uint64_t j, uint64_t k) {
  const uint64_t side = static_cast<uint64_t>(g.resolution(level)) + 1;
  if (side * side * side <= (uint64_t(1) << g.log2_table)) return i + side * j + side * side * k;
  const uint32_t h = static_cast<uint32_t>(i) ^ static_cast<uint32_t>(j * 2654435761ull) ^
                     static_cast<uint32_t>(k * 805459861ull);
  return h % (uint64_t(1) << g.log2_table);
}

// y = W x + b for W stored row-major [out][in].
std::vector<double> linear(const std::vector<double>& w, const std::vector<double>& b, const std::vector<double>& x) {
  std::vector<double> y(b.size());
  for (size_t o = 0; o < b.size(); ++o) {
    double v = b[o];
    for (size_t i = 0; i < x.size(); ++i) v += w[o * x.size() + i] * x[i];
    y[o] = v;
  }
  return y;
}

std::vector<double> run_mlp(const ReferenceField& f, const std::string& name, int layers, std::vector<double> x) {
  for (int k = 0; k < layers; ++k) {
    const std::string prefix = name + "." + std::to_string(k);
    x = linear(f.tensor(prefix + ".weight"), f.tensor(prefix + ".bias"), x);
    if (k + 1 < layers)
      for (auto& v : x) v = std::max(0.0, v);
  }
  return x;
}

}  // namespace

ReferenceField ReferenceField::from(const NerfField& field) {
  ReferenceField r;
  r.spec = field.spec;
  for (const auto& [name, t] : field.named_tensors()) {
    const at::Tensor d = t.to(at::kDouble).contiguous();
    r.tensors.emplace_back(name, std::vector<double>(d.data_ptr<double>(), d.data_ptr<double>() + d.numel()));
  }
  return r;
}

std::vector<double>& ReferenceField::tensor(const std::string& name) {
  for (auto& [n, v] : tensors)
    if (n == name) return v;
  fail("reference NeRF: no tensor " + name);
}

const std::vector<double>& ReferenceField::tensor(const std::string& name) const {
  return const_cast<ReferenceField*>(this)->tensor(name);
}

std::vector<double> reference_encode(const ReferenceField& f, const double p[3]) {
  const HashGridSpec& g = f.spec.grid;
  const std::vector<double>& table = f.tensor("grid.table");
  std::vector<double> out;
  int64_t offset = 0;
  for (int l = 0; l < g.levels; ++l) {
    const int res = g.resolution(l);
    int64_t cell[3];
    double frac[3];
    for (int a = 0; a < 3; ++a) {
      const double x = std::min(1.0, std::max(0.0, p[a])) * res;
      cell[a] = std::min<int64_t>(static_cast<int64_t>(std::floor(x)), res - 1);
      frac[a] = x - double(cell[a]);
    }
    for (int feature = 0; feature < g.features; ++feature) {
      double v = 0;
      for (int dx = 0; dx < 2; ++dx)
        for (int dy = 0; dy < 2; ++dy)
          for (int dz = 0; dz < 2; ++dz) {
            const double w = (dx ? frac[0] : 1 - frac[0]) * (dy ? frac[1] : 1 - frac[1]) * (dz ? frac[2] : 1 - frac[2]);
            const uint64_t row = reference_vertex(g, l, uint64_t(cell[0] + dx), uint64_t(cell[1] + dy), uint64_t(cell[2] + dz));
            v += w * table[static_cast<size_t>((offset + int64_t(row)) * g.features + feature)];
          }
      out.push_back(v);
    }
    offset += g.level_entries(l);
  }
  return out;
}

std::vector<double> reference_composite(const std::vector<double>& sigma, const std::vector<double>& delta,
                                        const std::vector<std::vector<double>>& values,
                                        const std::vector<double>& background) {
  std::vector<double> out(background.size(), 0.0);
  double transmittance = 1.0;
  for (size_t i = 0; i < sigma.size(); ++i) {
    const double alpha = 1.0 - std::exp(-sigma[i] * delta[i]);
    for (size_t c = 0; c < out.size(); ++c) out[c] += transmittance * alpha * values[i][c];
    transmittance *= 1.0 - alpha;
  }
  for (size_t c = 0; c < out.size(); ++c) out[c] += transmittance * background[c];
  return out;
}

std::vector<double> reference_render_ray(const ReferenceField& f, const double o[3], const double d[3], const float* s,
                                         int n) {
  const SceneBounds& b = f.spec.bounds;
  auto depth = [&](double u) { return 1.0 / ((1.0 - u) / b.near + u / b.far); };
  const double length = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) / b.unit;
  std::vector<double> sigma, delta;
  std::vector<std::vector<double>> values;
  for (int i = 0; i < n; ++i) {
    const double z = depth(s[i]);
    const double world[3] = {o[0] + z * d[0], o[1] + z * d[1], o[2] + z * d[2]};
    double p[3];
    reference_grid_point(b, world, p);
    const std::vector<double> raw = run_mlp(f, "density", 2, reference_encode(f, p));
    sigma.push_back(std::exp(std::min(raw[0], double(kMaxLogDensity))));
    std::vector<double> latent = run_mlp(f, "latent", 3, raw);
    for (auto& v : latent) v = 1.0 / (1.0 + std::exp(-v));
    values.push_back(latent);
    delta.push_back(i + 1 < n ? (depth(s[i + 1]) - z) * length : 1e10);
  }
  return reference_composite(sigma, delta, values,
                             std::vector<double>(f.spec.background.begin(), f.spec.background.end()));
}

double reference_loss(const ReferenceField& f, const Rays& rays, const at::Tensor& s, const at::Tensor& targets) {
  const at::Tensor t = targets.to(at::kDouble).contiguous();
  const int S = static_cast<int>(s.size(1)), C = f.spec.channels;
  double sum = 0;
  for (int64_t r = 0; r < rays.count; ++r) {
    const auto out = reference_render_ray(f, rays.origins + 3 * r, rays.directions + 3 * r, s.data_ptr<float>() + r * S, S);
    for (int c = 0; c < C; ++c) {
      const double e = out[static_cast<size_t>(c)] - t.data_ptr<double>()[r * C + c];
      sum += e * e;
    }
  }
  return sum / double(rays.count * C);
}

}  // namespace lrf::nerf
