#pragma once
// Front-to-back alpha compositing of depth-sorted, tile-binned splats (forward) and its exact backward,
// parallel over 16×16 tiles. Plain loops over raw arrays; images are channel-major [C, H, W].
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "lrf/splat/projection.h"

namespace lrf::splat {

constexpr float kMinAlpha = 1.0f / 255.0f;  // fainter splats are skipped
constexpr float kMaxAlpha = 0.99f;          // α is clamped here (keeps T invertible for the backward)
constexpr float kMinTransmittance = 1e-4f;  // a pixel stops before a splat would take T below this

struct RasterInputs {
  int width = 0, height = 0, tiles_x = 0, tiles_y = 0, channels = 0;
  const float* xy = nullptr;          // [N,2] pixels
  const float* conic = nullptr;       // [N,3]
  const float* opacity = nullptr;     // [N]
  const float* extent = nullptr;      // [N,2]
  const float* depth = nullptr;       // [N]
  const float* colors = nullptr;      // [N,C]
  const float* background = nullptr;  // [C]
  const int32_t* tile_offsets = nullptr;  // [tiles + 1]
  const int32_t* tile_ids = nullptr;
};

struct RasterForwardOutputs {
  float* image;       // [C,H,W]
  float* alpha;       // [H,W] 1 − T_final
  float* depth;       // [H,W] Σ z·α·T
  float* t_final;     // [H,W] saved for the backward
  int32_t* last;      // [H,W] position in the tile list of the last splat blended into the pixel (−1: none)
};

void rasterize_forward(const RasterInputs& in, const RasterForwardOutputs& out);

struct RasterBackwardInputs {
  const float* t_final;  // [H,W]
  const int32_t* last;   // [H,W]
  const float* d_image;  // [C,H,W]
  const float* d_alpha;  // [H,W] or nullptr (no gradient)
  const float* d_depth;  // [H,W] or nullptr
};

// Gradients per Gaussian; all overwritten (zeros for Gaussians that touch no pixel).
struct RasterGrads {
  float* xy;       // [N,2] pixel units
  float* conic;    // [N,3]
  float* opacity;  // [N]
  float* depth;    // [N] (from the depth output)
  float* colors;   // [N,C]
};

void rasterize_backward(int64_t n, const RasterInputs& in, const RasterBackwardInputs& bin, const RasterGrads& out);

// The α of a splat at offset (dx, dy) = mean − pixel centre; false when it is skipped. Forward and backward
// call this same function so that they take the same decisions bit for bit.
inline bool splat_alpha(float A, float B, float C, float o, float dx, float dy, float* alpha, float* gauss) {
  const float power = -0.5f * (A * dx * dx + C * dy * dy) - B * dx * dy;
  if (power > 0.f) return false;
  const float g = std::exp(power);
  const float a = std::min(kMaxAlpha, o * g);
  if (a < kMinAlpha) return false;
  *alpha = a;
  *gauss = g;
  return true;
}

// Pixels [j0, j1) × [i0, i1) of the tile [x0, x1) × [y0, y1) whose centres lie in the splat's α box.
struct PixelSpan {
  int i0, i1, j0, j1;
  bool empty() const { return i0 >= i1 || j0 >= j1; }
};
inline PixelSpan splat_span(float gx, float gy, float ex, float ey, int x0, int y0, int x1, int y1) {
  // Clamped in float before the conversion, so that far-away or huge splats cannot overflow an int.
  PixelSpan s;
  s.j0 = static_cast<int>(std::max(static_cast<float>(x0), std::ceil(gx - ex - 0.5f)));
  s.j1 = static_cast<int>(std::min(static_cast<float>(x1), std::floor(gx + ex - 0.5f) + 1.f));
  s.i0 = static_cast<int>(std::max(static_cast<float>(y0), std::ceil(gy - ey - 0.5f)));
  s.i1 = static_cast<int>(std::min(static_cast<float>(y1), std::floor(gy + ey - 0.5f) + 1.f));
  return s;
}

}  // namespace lrf::splat
