#include "lrf/nerf/nerf_render.h"

#include <algorithm>
#include <chrono>
#include <vector>

#include <ATen/ATen.h>
#include <ATen/Parallel.h>

#include "lrf/core/error.h"
#include "lrf/nerf/ray_sampling.h"
#include "lrf/nerf/volume_rendering.h"

namespace lrf::nerf {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Grid coordinates [rays·S, 3] and interval lengths [rays, S] of the samples s [rays, S].
void sample_geometry(const NerfField& f, const Rays& rays, const at::Tensor& s, at::Tensor* points, at::Tensor* delta) {
  const int64_t R = rays.count;
  const int S = static_cast<int>(s.size(1));
  *points = at::empty({R * S, 3}, at::kFloat);
  *delta = at::empty({R, S}, at::kFloat);
  const float* sp = s.data_ptr<float>();
  float* pp = points->data_ptr<float>();
  float* dp = delta->data_ptr<float>();
  at::parallel_for(0, R, 64, [&](int64_t begin, int64_t end) {
    for (int64_t r = begin; r < end; ++r)
      sample_points(f.spec.bounds, rays.origins + 3 * r, rays.directions + 3 * r, sp + r * S, S, pp + r * S * 3,
                    dp + r * S);
  });
}

// The field at a batch of points: what rendering needs, and what the backward pass needs when kept.
struct FieldOutputs {
  at::Tensor features;  // [n, grid.output_dim()]
  at::Tensor raw;       // [n, 1 + geo]: log-density and geometry features
  at::Tensor sigma;     // [n]
  at::Tensor values;    // [n, C] in (0, 1), when asked for
  std::vector<at::Tensor> density_inputs, latent_inputs;
};

FieldOutputs evaluate(const NerfField& f, const at::Tensor& points, bool keep, bool with_latent) {
  FieldOutputs o;
  const int64_t n = points.size(0);
  o.features = at::empty({n, f.spec.grid.output_dim()}, at::kFloat);
  hash_encode_forward(f.spec.grid, f.table.data_ptr<float>(), points.data_ptr<float>(), n,
                      o.features.data_ptr<float>());
  o.raw = f.density.forward(o.features, keep ? &o.density_inputs : nullptr);
  o.sigma = at::exp(o.raw.select(1, 0).clamp_max(kMaxLogDensity)).contiguous();
  if (with_latent) o.values = at::sigmoid(f.latent.forward(o.raw, keep ? &o.latent_inputs : nullptr)).contiguous();
  return o;
}

void check_rays(const NerfField& f, const Rays& rays, const at::Tensor& s) {
  if (s.dim() != 2 || s.size(0) != rays.count || s.scalar_type() != at::kFloat || !s.is_contiguous())
    fail("NeRF samples must be a contiguous float32 [rays, S] tensor");
  (void)f;
}

}  // namespace

at::Tensor place_samples(const NerfField& f, const Rays& rays, const at::Generator& generator) {
  const int64_t R = rays.count;
  const int nc = f.spec.coarse_samples, nf = f.spec.fine_samples;
  const bool jitter = generator.defined();
  at::Tensor coarse = at::empty({R, nc}, at::kFloat);
  at::Tensor coarse_jitter = jitter ? at::rand({R, nc}, generator, at::kFloat) : at::Tensor();
  {
    float* c = coarse.data_ptr<float>();
    const float* j = jitter ? coarse_jitter.data_ptr<float>() : nullptr;
    for (int64_t r = 0; r < R; ++r) stratified_samples(nc, j ? j + r * nc : nullptr, c + r * nc);
  }
  if (nf == 0) return coarse;

  at::Tensor points, delta;
  sample_geometry(f, rays, coarse, &points, &delta);
  const FieldOutputs e = evaluate(f, points, false, false);
  at::Tensor weights = at::empty({R, nc}, at::kFloat);
  composite_weights(e.sigma.data_ptr<float>(), delta.data_ptr<float>(), R, nc, weights.data_ptr<float>());

  at::Tensor fine_jitter = jitter ? at::rand({R, nf}, generator, at::kFloat) : at::Tensor();
  at::Tensor s = at::empty({R, nc + nf}, at::kFloat);
  const float* c = coarse.data_ptr<float>();
  const float* w = weights.data_ptr<float>();
  const float* j = jitter ? fine_jitter.data_ptr<float>() : nullptr;
  float* out = s.data_ptr<float>();
  at::parallel_for(0, R, 64, [&](int64_t begin, int64_t end) {
    std::vector<float> fine(static_cast<size_t>(nf));
    for (int64_t r = begin; r < end; ++r) {
      importance_samples(w + r * nc, nc, nf, j ? j + r * nf : nullptr, fine.data());
      std::merge(c + r * nc, c + (r + 1) * nc, fine.begin(), fine.end(), out + r * (nc + nf));
    }
  });
  return s;
}

at::Tensor render_samples(const NerfField& f, const Rays& rays, const at::Tensor& s) {
  check_rays(f, rays, s);
  const int64_t R = rays.count;
  const int S = static_cast<int>(s.size(1)), C = f.spec.channels;
  at::Tensor points, delta;
  sample_geometry(f, rays, s, &points, &delta);
  const FieldOutputs e = evaluate(f, points, false, true);
  at::Tensor out = at::empty({R, C}, at::kFloat);
  composite_forward(e.sigma.data_ptr<float>(), delta.data_ptr<float>(), e.values.data_ptr<float>(),
                    f.spec.background.data(), R, S, C, out.data_ptr<float>(), nullptr, nullptr);
  return out;
}

double loss_and_gradients(const NerfField& f, const Rays& rays, const at::Tensor& s, const at::Tensor& targets,
                          NerfField* grads, RenderTimings* timings) {
  check_rays(f, rays, s);
  const int64_t R = rays.count;
  const int S = static_cast<int>(s.size(1)), C = f.spec.channels;
  if (targets.sizes() != at::IntArrayRef({R, C})) fail("NeRF targets must be [rays, channels]");
  auto t0 = Clock::now();
  at::Tensor points, delta;
  sample_geometry(f, rays, s, &points, &delta);
  FieldOutputs e = evaluate(f, points, true, true);
  at::Tensor out = at::empty({R, C}, at::kFloat);
  composite_forward(e.sigma.data_ptr<float>(), delta.data_ptr<float>(), e.values.data_ptr<float>(),
                    f.spec.background.data(), R, S, C, out.data_ptr<float>(), nullptr, nullptr);
  const at::Tensor diff = out - targets.to(at::kFloat);
  const double loss = diff.to(at::kDouble).square().mean().item<double>();
  auto t1 = Clock::now();

  const at::Tensor d_out = (diff * (2.0 / double(R * C))).contiguous();
  at::Tensor d_sigma = at::empty({R * S}, at::kFloat), d_values = at::empty({R * S, C}, at::kFloat);
  composite_backward(e.sigma.data_ptr<float>(), delta.data_ptr<float>(), e.values.data_ptr<float>(),
                     f.spec.background.data(), d_out.data_ptr<float>(), R, S, C, d_sigma.data_ptr<float>(),
                     d_values.data_ptr<float>());
  const at::Tensor d_logits = d_values * e.values * (1.0 - e.values);  // through the sigmoid
  at::Tensor d_raw = f.latent.backward(e.latent_inputs, d_logits, &grads->latent);
  // σ = exp(min(raw₀, cap)): dσ/draw₀ = σ below the cap, 0 above it.
  const at::Tensor raw0 = e.raw.select(1, 0);
  d_raw.select(1, 0).add_(d_sigma * e.sigma * raw0.lt(kMaxLogDensity));
  const at::Tensor d_features = f.density.backward(e.density_inputs, d_raw, &grads->density).contiguous();
  hash_encode_backward(f.spec.grid, points.data_ptr<float>(), R * S, d_features.data_ptr<float>(),
                       grads->table.data_ptr<float>());
  if (timings) {
    timings->forward += std::chrono::duration<double>(t1 - t0).count();
    timings->backward += seconds_since(t1);
  }
  return loss;
}

at::Tensor render_view(const NerfField& f, const Camera& camera, int64_t rays_per_chunk) {
  std::vector<double> origins, directions;
  camera_rays(camera, &origins, &directions);
  const int64_t n = static_cast<int64_t>(camera.width) * camera.height;
  at::Tensor image = at::empty({n, f.spec.channels}, at::kFloat);
  for (int64_t begin = 0; begin < n; begin += rays_per_chunk) {
    Rays rays{origins.data() + 3 * begin, directions.data() + 3 * begin, std::min(rays_per_chunk, n - begin)};
    const at::Tensor s = place_samples(f, rays);
    image.narrow(0, begin, rays.count).copy_(render_samples(f, rays, s));
  }
  return image.view({camera.height, camera.width, f.spec.channels}).permute({2, 0, 1}).contiguous();
}

}  // namespace lrf::nerf
