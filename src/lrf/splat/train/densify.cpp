#include "lrf/splat/train/densify.h"

#include <algorithm>
#include <cmath>

#include <ATen/ATen.h>
#include <ATen/CPUGeneratorImpl.h>
#include <ATen/Parallel.h>

#include "lrf/splat/train/spatial_order.h"

namespace lrf::splat {

DensifySchedule DensifySchedule::for_iterations(int64_t iterations) {
  DensifySchedule s;
  iterations = std::max<int64_t>(iterations, 1);
  s.until = std::min<int64_t>(15000, iterations / 2);
  if (iterations >= kInriaShortRunSteps) return s;
  const double k = double(iterations) / double(kInriaShortRunSteps);
  auto scaled = [k](double v, int64_t floor) { return std::max<int64_t>(floor, std::llround(v * k)); };
  s.from = scaled(500, 0);
  // Statistics need a few views per densification: never densify more often than every 10 steps.
  s.interval = scaled(100, 10);
  s.opacity_reset_every = scaled(3000, 1);
  s.sh_degree_every = scaled(1000, 1);
  return s;
}

torch::Tensor quaternion_to_matrix(const torch::Tensor& quats) {
  auto q = quats / quats.norm(2, 1, true).clamp_min(1e-12);
  auto w = q.select(1, 0), x = q.select(1, 1), y = q.select(1, 2), z = q.select(1, 3);
  auto r = torch::stack({1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                         2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                         2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)},
                        1);
  return r.view({-1, 3, 3});
}

void Densifier::resize(int64_t n) {
  grad_accum = torch::zeros({n}, torch::kFloat32);
  denom = torch::zeros({n}, torch::kFloat32);
  max_radii = torch::zeros({n}, torch::kFloat32);
}

void Densifier::accumulate(const torch::Tensor& means2d_grad, const torch::Tensor& radii) {
  // One pass instead of eight tensor operations: this runs every step, over every Gaussian.
  const auto grad = means2d_grad.detach().to(torch::kFloat32).contiguous();
  const auto r = radii.to(torch::kInt32).contiguous();
  TORCH_CHECK(grad.dim() == 2 && grad.size(1) >= 2 && grad.size(0) == grad_accum.size(0) &&
                  r.numel() == grad_accum.size(0),
              "densification statistics out of step with the field");
  const int64_t n = grad_accum.size(0), stride = grad.size(1);
  const float* g = grad.data_ptr<float>();
  const int32_t* rp = r.data_ptr<int32_t>();
  float* acc = grad_accum.data_ptr<float>();
  float* den = denom.data_ptr<float>();
  float* mr = max_radii.data_ptr<float>();
  at::parallel_for(0, n, 16384, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) {
      if (rp[i] <= 0) continue;
      const float gx = g[stride * i], gy = g[stride * i + 1];
      acc[i] += std::sqrt(gx * gx + gy * gy);
      den[i] += 1.f;
      mr[i] = std::max(mr[i], static_cast<float>(rp[i]));
    }
  });
}

DensifyStats Densifier::densify_and_prune(Gaussians& g, GaussianAdam& adam, double extent, bool prune_screen_size,
                                          uint64_t seed, const DensifyOptions& o) {
  torch::NoGradGuard no_grad;
  DensifyStats stats;
  const int64_t n = g.size();
  stats.before = n;
  auto grads = grad_accum / denom;
  grads = torch::where(torch::isnan(grads), torch::zeros_like(grads), grads);
  auto max_scale = std::get<0>(g.log_scales.detach().max(1)).exp();
  auto hot = grads >= o.grad_threshold;
  auto clone_mask = hot & (max_scale <= o.percent_dense * extent);
  auto split_mask = hot & (max_scale > o.percent_dense * extent);

  // The cap: each clone or split adds one Gaussian; keep the candidates with the largest gradients.
  if (o.max_gaussians > 0) {
    const int64_t budget = std::max<int64_t>(0, o.max_gaussians - n);
    auto candidates = (clone_mask | split_mask).nonzero().flatten();
    if (candidates.numel() > budget) {
      auto order = std::get<1>(grads.index_select(0, candidates).sort(0, /*descending=*/true));
      auto chosen = candidates.index_select(0, order.narrow(0, 0, budget));
      auto allowed = torch::zeros({n}, torch::kBool);
      allowed.index_fill_(0, chosen, true);
      clone_mask &= allowed;
      split_mask &= allowed;
    }
  }
  auto clone_idx = clone_mask.nonzero().flatten();
  auto split_idx = split_mask.nonzero().flatten();
  stats.cloned = clone_idx.numel();
  stats.split = split_idx.numel();

  // Which rows survive. Clones are exact copies and share their parent's verdict except for the screen
  // size (they have no statistics yet); split parents go; children get their own scale test.
  auto opacity = torch::sigmoid(g.opacity_logits.detach()).squeeze(1);
  auto transparent = opacity < o.min_opacity;
  auto too_big_world = torch::zeros({n}, torch::kBool);
  auto too_big_screen = torch::zeros({n}, torch::kBool);
  if (prune_screen_size) {
    too_big_world = max_scale > o.max_world_scale * extent;
    too_big_screen = max_radii > o.max_screen_radius;
  }
  auto remove = transparent | too_big_world | too_big_screen;
  remove.index_fill_(0, split_idx, true);
  auto kept_orig = (~remove).nonzero().flatten();
  auto clone_ok = (~(transparent | too_big_world)).index_select(0, clone_idx);
  auto kept_clones = clone_idx.masked_select(clone_ok);
  auto child_parent = split_idx.repeat({2});
  auto child_ok = ~transparent.index_select(0, child_parent);
  if (prune_screen_size) child_ok &= (max_scale.index_select(0, child_parent) / 1.6) <= o.max_world_scale * extent;

  // Split children: two samples from each parent's Gaussian, scales / 1.6 (drawn for all, then kept).
  torch::Tensor child_means, child_log_scales;
  if (child_parent.numel() > 0) {
    auto gen = at::make_generator<at::CPUGeneratorImpl>(seed);
    auto scales = g.log_scales.detach().index_select(0, child_parent).exp();
    auto samples = at::normal(0.0, 1.0, {child_parent.numel(), 3}, gen) * scales;
    auto rot = quaternion_to_matrix(g.quats.detach().index_select(0, child_parent));
    child_means = torch::bmm(rot, samples.unsqueeze(2)).squeeze(2) + g.means.detach().index_select(0, child_parent);
    child_log_scales = (scales / 1.6).log();
    auto keep_child = child_ok.nonzero().flatten();
    child_means = child_means.index_select(0, keep_child);
    child_log_scales = child_log_scales.index_select(0, keep_child);
    child_parent = child_parent.index_select(0, keep_child);
  }

  // One gather per tensor: [kept originals | kept clones | kept children].
  auto source = torch::cat({kept_orig, kept_clones, child_parent});
  const int64_t first_new = kept_orig.numel();
  const int64_t first_child = first_new + kept_clones.numel();
  for (auto* p : g.parameters()) *p = p->detach().index_select(0, source);
  if (child_parent.numel() > 0) {
    g.means.narrow(0, first_child, child_parent.numel()).copy_(child_means);
    g.log_scales.narrow(0, first_child, child_parent.numel()).copy_(child_log_scales);
  }
  for (auto* p : g.parameters()) p->set_requires_grad(true);
  adam.gather_rows(source, first_new);
  resize(g.size());
  stats.after = g.size();
  stats.pruned = n + stats.cloned + 2 * stats.split - stats.split - stats.after;
  return stats;
}

void sort_spatially(Gaussians& g, GaussianAdam& adam) {
  torch::NoGradGuard no_grad;
  const auto order = spatial_order(g.means);
  g.permute_rows(order);
  adam.gather_rows(order, g.size());
}

void Densifier::reset_opacity(Gaussians& g, GaussianAdam& adam, const torch::Tensor& opacity_filter_coef) {
  torch::NoGradGuard no_grad;
  auto opacity = torch::sigmoid(g.opacity_logits.detach());
  torch::Tensor target;
  if (opacity_filter_coef.defined()) {
    // Mip-Splatting: cap the rendered (filtered) opacity, then undo the filter factor.
    auto coef = opacity_filter_coef.detach();
    target = torch::minimum(opacity * coef, torch::full_like(opacity, 0.01)) / coef;
  } else {
    target = torch::minimum(opacity, torch::full_like(opacity, 0.01));
  }
  target = target.clamp(1e-6, 1 - 1e-6);
  g.opacity_logits = torch::log(target / (1 - target)).contiguous().set_requires_grad(true);
  adam.reset_group(3);
}

}  // namespace lrf::splat
