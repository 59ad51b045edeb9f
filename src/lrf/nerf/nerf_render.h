#pragma once
// Rendering a latent NeRF along rays, and the gradient of the training loss. Per batch of rays:
//   1. coarse samples, stratified in disparity (ray_sampling.h); their densities alone (no latent MLP),
//      composited into weights;
//   2. fine samples from those weights; coarse and fine sorted together;
//   3. every sample through the hash grid and both MLPs; volume rendering (volume_rendering.h).
// Training differentiates step 3 only, as NeRF does: sample positions carry no gradient.
// Sample placement is random while training (a generator) and fixed when rendering (bin centres), so a
// rendered view is a deterministic function of the field.
#include <cstdint>

#include <ATen/Tensor.h>
#include <ATen/core/Generator.h>

#include "lrf/nerf/nerf_field.h"
#include "lrf/scene/camera.h"

namespace lrf::nerf {

struct Rays {
  const double* origins = nullptr;     // [count, 3]
  const double* directions = nullptr;  // [count, 3], component 1 along each camera's optical axis
  int64_t count = 0;
};

struct RenderTimings {
  double sampling = 0, forward = 0, backward = 0;  // seconds
};

// Sorted sample parameters s [rays, coarse + fine] (see ray_sampling.h); jittered when `generator` is
// defined, else at the bin centres.
at::Tensor place_samples(const NerfField& field, const Rays& rays, const at::Generator& generator = {});

// The rendered normalised latents [rays, C] at the given samples s [rays, S].
at::Tensor render_samples(const NerfField& field, const Rays& rays, const at::Tensor& s);

// The mean squared error over rays and channels of the rendering at samples s against targets [rays, C],
// and its gradient added into `grads` (a field of the same layout, e.g. field.zeros_like()).
double loss_and_gradients(const NerfField& field, const Rays& rays, const at::Tensor& s, const at::Tensor& targets,
                          NerfField* grads, RenderTimings* timings = nullptr);

// Every pixel of `camera` (at latent resolution), deterministic sampling: [C, height, width].
at::Tensor render_view(const NerfField& field, const Camera& camera, int64_t rays_per_chunk = 4096);

}  // namespace lrf::nerf
