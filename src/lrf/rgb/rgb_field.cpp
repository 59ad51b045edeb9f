#include "lrf/rgb/rgb_field.h"

#include <ATen/CPUGeneratorImpl.h>

#include "lrf/core/error.h"
#include "lrf/core/log.h"

namespace lrf::splat {

torch::Tensor image_to_tensor(const cv::Mat& rgb) {
  if (rgb.type() != CV_32FC3) fail("image_to_tensor: expected a CV_32FC3 image");
  cv::Mat m = rgb.isContinuous() ? rgb : rgb.clone();
  return torch::from_blob(m.data, {m.rows, m.cols, 3}, torch::kFloat32).permute({2, 0, 1}).contiguous().clone();
}

cv::Mat tensor_to_image(const torch::Tensor& chw) {
  if (chw.dim() != 3 || chw.size(0) != 3) fail("tensor_to_image: expected [3, H, W]");
  auto hwc = chw.detach().to(torch::kFloat32).clamp(0, 1).permute({1, 2, 0}).contiguous();
  cv::Mat m(static_cast<int>(hwc.size(0)), static_cast<int>(hwc.size(1)), CV_32FC3, hwc.data_ptr<float>());
  return m.clone();
}

std::vector<TrainView> rgb_views(const Scene& scene, const std::vector<int>& indices) {
  std::vector<TrainView> views;
  views.reserve(indices.size());
  for (int i : indices) {
    const auto& v = scene.views[static_cast<size_t>(i)];
    auto target = image_to_tensor(scene.load_image(i));
    if (target.size(1) != v.camera.height || target.size(2) != v.camera.width)
      fail(v.image_path, "decoded image size differs from the camera's");
    views.push_back({v.name, v.camera, target});
  }
  return views;
}

Gaussians init_rgb_field(const Scene& scene, int max_sh_degree, uint64_t seed, const InitPointsOptions& options,
                         nlohmann::json* origin) {
  const InitialPoints init = choose_initial_points(scene, options);
  log_info("initial points: " + init.description);
  if (origin) *origin = init.record;
  if (!init.points.empty()) {
    const int64_t n = static_cast<int64_t>(init.points.size());
    auto xyz = torch::empty({n, 3}, torch::kFloat32);
    auto rgb = torch::empty({n, 3}, torch::kFloat32);
    auto px = xyz.accessor<float, 2>();
    auto pc = rgb.accessor<float, 2>();
    for (int64_t i = 0; i < n; ++i)
      for (int a = 0; a < 3; ++a) {
        px[i][a] = static_cast<float>(init.points[static_cast<size_t>(i)].xyz[a]);
        pc[i][a] = init.points[static_cast<size_t>(i)].rgb[a];
      }
    return gaussians_from_points(xyz, rgb, max_sh_degree);
  }
  auto xyz = random_points(kRandomInitPoints, scene.camera_mean(), scene.camera_extent(), seed);
  auto gen = at::make_generator<at::CPUGeneratorImpl>(seed + 1);
  auto rgb = at::rand({kRandomInitPoints, 3}, gen, torch::kFloat32);
  return gaussians_from_points(xyz, rgb, max_sh_degree);
}

}  // namespace lrf::splat
