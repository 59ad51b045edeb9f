#include "lrf/latent/latent_field.h"

#include <ATen/ATen.h>
#include <ATen/CPUGeneratorImpl.h>
#include <torch/torch.h>

#include "lrf/autoencoder/image_tensor.h"
#include "lrf/core/error.h"
#include "lrf/latent/latent_init.h"
#include "lrf/rgb/rgb_field.h"

namespace lrf {

Camera latent_camera(const Camera& image_camera, int factor) {
  if (image_camera.width % factor || image_camera.height % factor)
    fail("a latent camera needs an image size that is a multiple of " + std::to_string(factor));
  return image_camera.resized(image_camera.width / factor, image_camera.height / factor);
}

LatentInit parse_latent_init(const std::string& name) {
  if (name == "latents") return LatentInit::latents;
  if (name == "rgb") return LatentInit::rgb;
  fail_usage("--init must be 'latents' or 'rgb', got '" + name + "'");
}

LatentTrainingData prepare_latent_training(const Scene& scene, const std::vector<torch::Tensor>& train_latents,
                                           LatentInit init, int sh_degree, uint64_t seed,
                                           const InitPointsOptions& points, double rgb_guide) {
  if (train_latents.size() != scene.train_indices.size()) fail("one latent per training view expected");
  LatentTrainingData data;
  data.range = compute_latent_range(train_latents);
  std::vector<Camera> cameras;
  std::vector<torch::Tensor> normalised;
  for (size_t k = 0; k < train_latents.size(); ++k) {
    const View& v = scene.views.at(static_cast<size_t>(scene.train_indices[k]));
    auto zn = data.range.normalize(train_latents[k]).contiguous();
    if (rgb_guide > 0) {
      const torch::Tensor image = image_to_batch(scene.load_image(scene.train_indices[k]));  // [1, 3, 8h, 8w]
      const torch::Tensor small = torch::avg_pool2d(image, 8)[0] * rgb_guide;
      zn = torch::cat({zn, small.to(zn.dtype())}, 0).contiguous();
    }
    cameras.push_back(v.camera);
    normalised.push_back(zn);
    data.views.push_back({v.name, latent_camera(v.camera), zn});
  }
  const int channels = data.range.channels() + (rgb_guide > 0 ? 3 : 0);
  torch::Tensor xyz, features;
  const InitialPoints initial = choose_initial_points(scene, points);
  data.init_points = initial.record;
  if (!initial.points.empty()) {
    const int64_t n = static_cast<int64_t>(initial.points.size());
    xyz = torch::empty({n, 3}, torch::kFloat32);
    auto rgb = torch::empty({n, 3}, torch::kFloat32);
    std::vector<Eigen::Vector3d> pts;
    for (int64_t i = 0; i < n; ++i) {
      const auto& p = initial.points[static_cast<size_t>(i)];
      pts.push_back(p.xyz);
      for (int a = 0; a < 3; ++a) {
        xyz[i][a] = static_cast<float>(p.xyz[a]);
        rgb[i][a] = p.rgb[a];
      }
    }
    if (init == LatentInit::latents) {
      features = sample_latents_at_points(cameras, normalised, pts);
      data.init_description = initial.description + ", features sampled from the training latents";
    } else {
      features = rgb_into_first_channels(rgb, channels);
      data.init_description = initial.description + ", RGB in the first latent channels (paper code)";
    }
  } else {
    xyz = splat::random_points(splat::kRandomInitPoints, scene.camera_mean(), scene.camera_extent(), seed);
    auto gen = at::make_generator<at::CPUGeneratorImpl>(seed + 1);
    features = at::rand({splat::kRandomInitPoints, channels}, gen, torch::kFloat32);
    data.init_description = std::to_string(splat::kRandomInitPoints) + " " + initial.description;
  }
  data.init = splat::gaussians_from_points(xyz, features, sh_degree);
  return data;
}

torch::Tensor decode_normalised(Autoencoder& ae, const LatentRange& range, const torch::Tensor& normalised) {
  torch::NoGradGuard no_grad;
  auto z = range.denormalize(normalised.to(torch::kFloat32)).unsqueeze(0);
  return ae.decode(z).squeeze(0);
}

}  // namespace lrf
