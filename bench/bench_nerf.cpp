// Latent NeRF timings: one training step split by phase (sampling with the coarse pass, forward, backward,
// Adam) and its kernels alone (hash encoding forward / backward, the MLPs, volume rendering), at the
// default architecture (16 levels × 2 features, 2^17 entries, 64-wide MLPs, 32 channels) and the default
// batch (1024 rays × 32 + 32 samples) on fern-like rays. The baseline, measured back to back in the same
// run, is the float64 reference renderer (nerf_reference.h) on a few rays: the ratio is samples per second
// of the fast forward over the reference's.
//
// usage: bench_nerf [--threads N] [--steps N] [--rays N] [--samples N] [--hash-log2 N]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <ATen/ATen.h>
#include <ATen/CPUGeneratorImpl.h>

#include "lrf/core/threads.h"
#include "lrf/nerf/hash_encoding.h"
#include "lrf/nerf/nerf_reference.h"
#include "lrf/nerf/nerf_render.h"
#include "lrf/nerf/ray_sampling.h"
#include "lrf/nerf/nerf_trainer.h"

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

int usage() {
  std::fprintf(stderr, "usage: bench_nerf [--threads N] [--steps N] [--rays N] [--samples N] [--hash-log2 N]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  int threads = 1, steps = 10, rays = 1024, samples = 32, log2_table = 17;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) return usage();
    const int v = std::atoi(argv[++i]);
    if (a == "--threads") threads = v;
    else if (a == "--steps") steps = std::max(1, v);
    else if (a == "--rays") rays = std::max(1, v);
    else if (a == "--samples") samples = std::max(2, v);
    else if (a == "--hash-log2") log2_table = v;
    else return usage();
  }
  lrf::set_thread_count(threads);
  using namespace lrf::nerf;
  // Fern at images_8 in latent space: 63×47 rays per view, 17 views, depths ~15..95 around a box of ~20 units.
  NerfSpec spec;
  spec.grid.log2_table = log2_table;
  spec.coarse_samples = samples;
  spec.fine_samples = samples;
  spec.bounds.near = 15;
  spec.bounds.far = 95;
  spec.bounds.center = Eigen::Vector3d(0, 0, 35);
  spec.bounds.half = Eigen::Vector3d(15, 11, 25);
  spec.bounds.unit = spec.bounds.half.mean();
  spec.background.assign(32, 0.0f);
  std::vector<lrf::Camera> cameras;
  std::vector<at::Tensor> latents;
  auto gen = at::make_generator<at::CPUGeneratorImpl>(0);
  for (int k = 0; k < 17; ++k) {
    lrf::Camera c;
    c.width = 63, c.height = 47, c.fx = c.fy = 51, c.cx = 31.5, c.cy = 23.5;
    c.t = Eigen::Vector3d(-0.5 * (k - 8), 0.1 * (k % 3), 0);
    cameras.push_back(c);
    latents.push_back(at::rand({32, 47, 63}, gen, at::kFloat));
  }
  NerfTrainOptions to;
  to.iterations = steps + 1;
  to.rays_per_step = rays;
  NerfTrainer trainer(NerfField::create(spec, 0), training_rays(cameras, latents), to);
  std::printf("latent NeRF: %lld parameters, %d rays x %d samples per step, %d threads\n",
              static_cast<long long>(trainer.field().parameter_count()), rays, spec.samples(), threads);
  trainer.step();  // warm-up (allocations, BLAS)
  double sampling = 0, forward = 0, backward = 0, adam = 0;
  auto t0 = Clock::now();
  for (int k = 0; k < steps; ++k) {
    const NerfStepResult r = trainer.step();
    sampling += r.timings.sampling;
    forward += r.timings.forward;
    backward += r.timings.backward;
    adam += r.optimizer_seconds;
  }
  const double step_ms = 1000 * since(t0) / steps;
  std::printf("training step: %.1f ms (sampling %.1f, forward %.1f, backward %.1f, adam %.1f)\n", step_ms,
              1000 * sampling / steps, 1000 * forward / steps, 1000 * backward / steps, 1000 * adam / steps);
  std::printf("  one hour of training: %.0f steps\n", 3600e3 / step_ms);

  // Kernels alone on one step's worth of samples.
  const NerfField& f = trainer.field();
  const int64_t n = int64_t(rays) * spec.samples();
  const at::Tensor points = at::rand({n, 3}, gen, at::kFloat);
  at::Tensor features = at::empty({n, spec.grid.output_dim()}, at::kFloat);
  t0 = Clock::now();
  hash_encode_forward(spec.grid, f.table.data_ptr<float>(), points.data_ptr<float>(), n, features.data_ptr<float>());
  const double encode = since(t0);
  at::Tensor d_table = at::zeros_like(f.table);
  const at::Tensor d_features = at::randn({n, spec.grid.output_dim()}, gen, at::kFloat);
  t0 = Clock::now();
  hash_encode_backward(spec.grid, points.data_ptr<float>(), n, d_features.data_ptr<float>(), d_table.data_ptr<float>());
  const double encode_back = since(t0);
  t0 = Clock::now();
  const at::Tensor raw = f.density.forward(features);
  const at::Tensor latent = f.latent.forward(raw);
  const double mlps = since(t0);
  std::printf("kernels on %lld samples: encode %.1f ms, encode backward %.1f ms, both MLPs forward %.1f ms\n",
              static_cast<long long>(n), 1000 * encode, 1000 * encode_back, 1000 * mlps);

  // Render speed against the float64 reference, back to back on the same rays and samples.
  std::vector<double> o, d;
  camera_rays(cameras[0], &o, &d);
  const int64_t view_rays = int64_t(o.size() / 3);
  t0 = Clock::now();
  const at::Tensor view = render_view(f, cameras[0]);
  const double fast = since(t0);
  const int reference_rays = 16;
  const Rays some{o.data(), d.data(), reference_rays};
  const at::Tensor s = place_samples(f, some);
  const ReferenceField ref = ReferenceField::from(f);
  t0 = Clock::now();
  for (int r = 0; r < reference_rays; ++r)
    reference_render_ray(ref, o.data() + 3 * r, d.data() + 3 * r, s.data_ptr<float>() + r * s.size(1),
                         static_cast<int>(s.size(1)));
  const double reference = since(t0) / reference_rays * double(view_rays);
  std::printf("render one 63x47 view: %.1f ms (%.2f views/s); float64 reference %.0f ms: %.1fx\n", 1000 * fast,
              1.0 / fast, 1000 * reference, reference / fast);
  return view.numel() > 0 && latent.numel() > 0 ? 0 : 1;
}
