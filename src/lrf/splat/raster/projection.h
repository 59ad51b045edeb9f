#pragma once
// Per-Gaussian projection of 3D Gaussians to screen-space conics (EWA splatting with the 3DGS conventions)
// and its exact backward. Plain loops over raw arrays, so that another backend can reuse the math: the
// forward in projection_lanes.h, the backward in projection_backward_lanes.h, both on vector lanes at the
// width the compositing uses (raster_dispatch.cpp).
#include <cstdint>

namespace lrf::splat {

constexpr int kTileSize = 16;
// Inria floors the eigenvalue discriminant so that near-isotropic footprints get a safe radius.
constexpr float kMinDiscriminant = 0.1f;
// Below this ratio the Mip-Splatting compensation is floored (as its reference code does).
constexpr float kMinMipRatio = 0.000025f;
// Splats projecting 1e7 px away or 1e7 px wide would overflow the tile arithmetic: they are culled (the
// first kind is off-screen anyway; the second is a degenerate, uniform veil).
constexpr float kFarBound = 1e7f;

// Everything about the view that the kernels need, as plain numbers.
struct Viewpoint {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};  // world -> camera rotation, row-major
  double t[3] = {0, 0, 0};
  double campos[3] = {0, 0, 0};  // camera centre in world coordinates (−Rᵀt)
  double near = 0.01;
  double dilation = 0.3;
  bool mip_2d_filter = false;
  int tiles_x() const { return (width + kTileSize - 1) / kTileSize; }
  int tiles_y() const { return (height + kTileSize - 1) / kTileSize; }
};

// Per-Gaussian outputs of the projection; every array has N rows.
struct Projected {
  float* xy;       // [N,2] projected mean in pixels (pixel (i, j) has its centre at (j + 0.5, i + 0.5))
  float* depth;    // [N]   camera-space z
  float* conic;    // [N,3] (A, B, C): σ = ½(A·dx² + C·dy²) + B·dx·dy, the inverse of the dilated Σ2
  float* opacity;  // [N]   sigmoid(logit), times the Mip compensation √(det Σ2 / det Σ2') with the 2D filter
  float* extent;   // [N,2] half-widths (px) of a box around xy holding every point where α >= 1/255
  int32_t* radii;  // [N]   ⌈3·√λmax⌉ (Inria), 0 when culled
  int32_t* rect;   // [N,4] tiles [x0, x1) × [y0, y1) the Gaussian is binned to; empty when it cannot show
};

// Runs kWidth Gaussians at a time, at the vector width the compositing uses (projection_lanes.h,
// raster_dispatch.cpp); every width gives the same bits.
void project_forward(int64_t n, const float* means, const float* log_scales, const float* quats,
                     const float* opacity_logits, const Viewpoint& v, const Projected& out);

// Gradients of the loss w.r.t. the projection's outputs (pixel units, as the rasterizer produces them).
struct ProjectedGrads {
  const float* xy;       // [N,2]
  const float* conic;    // [N,3] w.r.t. (A, B, C) as independent numbers
  const float* opacity;  // [N]
  const float* depth;    // [N]
};

// Overwrites d_means, d_log_scales, d_quats and d_opacity_logits (zeros for culled Gaussians and for those
// without an upstream gradient). Every width gives the same bits.
void project_backward(int64_t n, const float* means, const float* log_scales, const float* quats,
                      const float* opacity_logits, const int32_t* radii, const Viewpoint& v,
                      const ProjectedGrads& g, float* d_means, float* d_log_scales, float* d_quats,
                      float* d_opacity_logits);

}  // namespace lrf::splat
