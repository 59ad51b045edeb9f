#pragma once
// Rendering a stored field (as written to point_cloud.ply) for any camera, with the settings it was
// trained with. A field trained with Mip-Splatting is stored with its 3D filter baked in, so only the
// 2D Mip filter needs switching on here.
#include <torch/types.h>

#include "lrf/scene/camera.h"
#include "lrf/splat/gaussians.h"
#include "lrf/splat/raster/rasterize.h"

namespace lrf::splat {

struct FieldRenderOptions {
  int sh_degree = 3;
  bool mip = false;
  torch::Tensor background;  // [C]; undefined = zeros
};

RasterSettings field_settings(const Camera& camera, int channels, const FieldRenderOptions& options);
// No autograd; returns the full RenderOutput (image [C, H, W], alpha, depth, ...).
RenderOutput render_field(const Gaussians& g, const Camera& camera, const FieldRenderOptions& options);

}  // namespace lrf::splat
