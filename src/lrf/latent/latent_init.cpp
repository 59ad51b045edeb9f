#include "lrf/latent/latent_init.h"

#include <ATen/ATen.h>

#include "lrf/align/correspondence_loss.h"
#include "lrf/core/error.h"

namespace lrf {

torch::Tensor sample_latents_at_points(const std::vector<Camera>& cameras, const std::vector<torch::Tensor>& latents,
                                       const std::vector<Eigen::Vector3d>& points, int factor) {
  if (cameras.size() != latents.size() || latents.empty()) fail("sample_latents_at_points: one latent per camera");
  const int64_t C = latents[0].size(0);
  const int64_t N = static_cast<int64_t>(points.size());
  auto sum = at::zeros({N, C}, at::kFloat);
  auto count = at::zeros({N, 1}, at::kFloat);
  for (size_t v = 0; v < cameras.size(); ++v) {
    const Camera& cam = cameras[v];
    std::vector<int64_t> idx;
    std::vector<float> px;
    for (int64_t n = 0; n < N; ++n) {
      Eigen::Vector2d p;
      double depth;
      if (!cam.project(points[n], &p, &depth) || depth < 1e-6) continue;
      if (p.x() < 0 || p.y() < 0 || p.x() >= cam.width || p.y() >= cam.height) continue;
      idx.push_back(n);
      px.push_back(static_cast<float>(p.x()));
      px.push_back(static_cast<float>(p.y()));
    }
    if (idx.empty()) continue;
    auto pixels = at::tensor(px, at::kFloat).view({-1, 2});
    auto values = sample_latent_at_pixels(latents[v].to(at::kFloat), pixels, factor);  // [M, C]
    auto rows = at::tensor(idx, at::kLong);
    sum.index_add_(0, rows, values);
    count.index_add_(0, rows, at::ones({static_cast<int64_t>(idx.size()), 1}, at::kFloat));
  }
  auto seen = count > 0;
  return at::where(seen, sum / count.clamp_min(1), at::full_like(sum, 0.5f));
}

torch::Tensor rgb_into_first_channels(const torch::Tensor& rgb, int channels) {
  auto out = at::full({rgb.size(0), channels}, 0.5f, at::kFloat);
  int64_t k = std::min<int64_t>(3, channels);
  out.narrow(1, 0, k).copy_(rgb.narrow(1, 0, k));
  return out;
}

}  // namespace lrf
