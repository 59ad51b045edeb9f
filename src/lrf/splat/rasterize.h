#pragma once
// Contract of the rasterizer (implemented on branch `raster`); this copy lets the trainer build until
// that branch is merged, and is replaced by the raster branch's file on merge.
#include <Eigen/Core>
#include <torch/types.h>

#include "lrf/scene/camera.h"

namespace lrf::splat {

struct RasterSettings {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  int sh_degree = 0;
  torch::Tensor background;  // [C]
  double near = 0.01;
  double dilation = 0.3;
  bool mip_2d_filter = false;  // Mip-Splatting 2D filter: dilation is the filter variance (0.1)
};

RasterSettings settings_for(const lrf::Camera& cam, int sh_degree, torch::Tensor background);

struct RenderOutput {
  torch::Tensor image;    // [C, H, W]
  torch::Tensor alpha;    // [1, H, W]
  torch::Tensor depth;    // [1, H, W]
  torch::Tensor means2d;  // [N, 2]; .grad() after backward: screen-space gradient (Inria NDC convention)
  torch::Tensor radii;    // [N] int32, 0 = culled
};

RenderOutput render(const torch::Tensor& means, const torch::Tensor& log_scales, const torch::Tensor& quats,
                    const torch::Tensor& opacity_logits, const torch::Tensor& sh, const RasterSettings& s);

}  // namespace lrf::splat
