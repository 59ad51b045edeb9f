#pragma once
// Stage II's starting features: each SfM point takes the mean of the normalised training latents at its
// projections (bilinear, latent = image / 8), over the training views that see it in front of the
// camera and inside the frame. This starts every Gaussian near the value it must render, unlike the
// paper code's quirk of copying the point's RGB into the first three latent channels (`--init rgb`).
#include <vector>

#include <Eigen/Core>
#include <torch/types.h>

#include "lrf/scene/camera.h"

namespace lrf {

// latents[k] is the normalised latent [C, H/8, W/8] seen through cameras[k] (cameras at image
// resolution). points: xyz. Points no view sees get 0.5 in every channel. Returns [N, C] float32.
torch::Tensor sample_latents_at_points(const std::vector<Camera>& cameras, const std::vector<torch::Tensor>& latents,
                                       const std::vector<Eigen::Vector3d>& points, int factor = 8);

// The paper code's start: RGB in the first three channels, 0.5 elsewhere. rgb [N, 3] in [0, 1].
torch::Tensor rgb_into_first_channels(const torch::Tensor& rgb, int channels);

}  // namespace lrf
