#pragma once
// Differentiable N-channel Gaussian rasterizer (3D Gaussian Splatting conventions, DESIGN.md §5) on CPU.
//
// Pixel convention: the one of lrf::Camera. A mean projects to (fx·x/z + cx, fy·y/z + cy) and pixel (i, j)
// is sampled at its centre (j + 0.5, i + 0.5). Inria's rasterizer maps NDC to pixels with a −0.5 shift and
// samples at integer (j, i): for a centred principal point (cx = W/2) the two are the same numbers.
//
// The forward matches 3DGS. The backward is the exact derivative of that forward, which differs from
// Inria's CUDA backward in two corner cases: where α is clamped at 0.99 it passes no gradient to the
// opacity and shape (Inria's passes one through the clamp), and where x/z or y/z is clamped for the
// Jacobian (splats far outside the view) the clamped ratio is held fixed. With an off-centre principal
// point the Jacobian clamp is 1.3× each side's own extent (Inria's ±1.3·tan(fov/2) when centred).
// CPU kernels: OpenMP over 16×16 tiles, SSE2 over 4 pixels of a row; see projection.h, binning.h,
// raster_kernels.h and sh.h.
#include <torch/torch.h>

#include <Eigen/Core>

#include "lrf/scene/camera.h"

namespace lrf::splat {

struct ShGradientSink;

struct RasterSettings {
  int width = 0, height = 0;             // output resolution (any camera, not only the training one)
  double fx = 0, fy = 0, cx = 0, cy = 0;  // intrinsics at that resolution
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  // world -> camera (lrf::Camera convention)
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  int sh_degree = 0;         // active SH degree (<= the degree the sh tensor holds)
  torch::Tensor background;  // [C] float32, per-channel background (undefined means zeros)
  double near = 0.01;        // cull z < near
  double dilation = 0.3;     // the low-pass added to Σ2's diagonal
  bool mip_2d_filter = false;  // Mip-Splatting 2D filter: dilation becomes the filter variance
                               //   (0.1 in Mip-Splatting) and opacity is scaled by sqrt(det Σ2 / det Σ2')
  // Set by a training step: the backward hands the SH gradient row by row to this sink (sh.h) and returns
  // no gradient for sh. It must outlive the backward pass.
  const ShGradientSink* sh_gradient_sink = nullptr;
};

RasterSettings settings_for(const lrf::Camera& cam, int sh_degree, torch::Tensor background);

struct RenderOutput {
  torch::Tensor image;    // [C, H, W] float32
  torch::Tensor alpha;    // [1, H, W] accumulated opacity (1 - T_final), differentiable
  torch::Tensor depth;    // [1, H, W] alpha-weighted camera-space z (un-normalised), differentiable
  torch::Tensor means2d;  // [N, 2] projected means in pixels; after backward, means2d.grad() holds the
                          //   screen-space positional gradient in the Inria convention (d loss / d NDC:
                          //   pixel gradient × 0.5·W and × 0.5·H) used by densification
  torch::Tensor radii;    // [N] int32, 0 for culled Gaussians
};

// means [N,3], log_scales [N,3], quats [N,4] (w,x,y,z, not necessarily normalised), opacity_logits [N,1],
// sh [N,K,C] with K = (D+1)^2 for the degree D the tensor holds, C >= 1; all float32 on the CPU.
// Differentiable w.r.t. all five tensors (torch autograd). Colour = max(SH(dir) + 0.5, 0) per channel with
// dir = normalize(μ − camera centre).
RenderOutput render(const torch::Tensor& means, const torch::Tensor& log_scales, const torch::Tensor& quats,
                    const torch::Tensor& opacity_logits, const torch::Tensor& sh, const RasterSettings& s);

}  // namespace lrf::splat
