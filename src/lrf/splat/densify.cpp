#include "lrf/splat/densify.h"

#include <algorithm>
#include <cmath>

#include <ATen/ATen.h>
#include <ATen/CPUGeneratorImpl.h>

namespace lrf::splat {

DensifySchedule DensifySchedule::for_iterations(int64_t iterations) {
  DensifySchedule s;
  if (iterations >= 30000) return s;
  const double k = double(std::max<int64_t>(iterations, 1)) / 30000.0;
  auto scaled = [k](double v, int64_t floor) { return std::max<int64_t>(floor, std::llround(v * k)); };
  s.from = scaled(500, 0);
  s.until = scaled(15000, 1);
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

void append_gaussians(Gaussians& g, const Gaussians& extra) {
  auto dst = g.parameters();
  auto src = extra.parameters();
  for (size_t i = 0; i < dst.size(); ++i) *dst[i] = torch::cat({dst[i]->detach(), src[i]->detach()}, 0);
  g.make_leaves();
}

void select_gaussians(Gaussians& g, const torch::Tensor& index) {
  for (auto* p : g.parameters()) *p = p->detach().index_select(0, index);
  g.make_leaves();
}

void Densifier::resize(int64_t n) {
  grad_accum = torch::zeros({n}, torch::kFloat32);
  denom = torch::zeros({n}, torch::kFloat32);
  max_radii = torch::zeros({n}, torch::kFloat32);
}

void Densifier::accumulate(const torch::Tensor& means2d_grad, const torch::Tensor& radii) {
  auto visible = radii > 0;
  auto norm = means2d_grad.detach().narrow(1, 0, 2).norm(2, 1);
  grad_accum.add_(torch::where(visible, norm, torch::zeros_like(norm)));
  denom.add_(visible.to(torch::kFloat32));
  max_radii.copy_(torch::where(visible, torch::maximum(max_radii, radii.to(torch::kFloat32)), max_radii));
}

void Densifier::select_rows(const torch::Tensor& index, int64_t extra) {
  for (auto* t : {&grad_accum, &denom, &max_radii})
    *t = torch::cat({t->index_select(0, index), torch::zeros({extra}, torch::kFloat32)});
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

  // Clones: exact copies. Split children: two samples from each parent, scales / 1.6.
  Gaussians added;
  added.max_sh_degree = g.max_sh_degree;
  {
    auto src = g.parameters();
    auto dst = added.parameters();
    auto split2 = split_idx.repeat({2});
    auto both = torch::cat({clone_idx, split2});
    for (size_t i = 0; i < src.size(); ++i) *dst[i] = src[i]->detach().index_select(0, both);
    if (split2.numel() > 0) {
      auto gen = at::make_generator<at::CPUGeneratorImpl>(seed);
      auto scales = g.log_scales.detach().index_select(0, split2).exp();
      auto samples = at::normal(0.0, 1.0, {split2.numel(), 3}, gen) * scales;
      auto rot = quaternion_to_matrix(g.quats.detach().index_select(0, split2));
      auto means = torch::bmm(rot, samples.unsqueeze(2)).squeeze(2) + g.means.detach().index_select(0, split2);
      added.means.narrow(0, clone_idx.numel(), split2.numel()).copy_(means);
      added.log_scales.narrow(0, clone_idx.numel(), split2.numel()).copy_((scales / 1.6).log());
    }
  }
  const int64_t extra = added.size();
  append_gaussians(g, added);
  adam.select_rows(torch::arange(n), extra);
  // Children start with no screen statistics; parents keep theirs for the screen-size test below.
  select_rows(torch::arange(n), extra);

  // Prune: split parents, transparent Gaussians, and (after the first reset) huge ones.
  auto remove = torch::zeros({n + extra}, torch::kBool);
  remove.index_fill_(0, split_idx, true);
  auto opacity = torch::sigmoid(g.opacity_logits.detach()).squeeze(1);
  remove |= opacity < o.min_opacity;
  if (prune_screen_size) {
    auto new_max_scale = std::get<0>(g.log_scales.detach().max(1)).exp();
    remove |= max_radii > o.max_screen_radius;
    remove |= new_max_scale > o.max_world_scale * extent;
  }
  auto keep = (~remove).nonzero().flatten();
  stats.pruned = n + extra - keep.numel() - stats.split;
  select_gaussians(g, keep);
  adam.select_rows(keep, 0);
  resize(g.size());
  stats.after = g.size();
  return stats;
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
