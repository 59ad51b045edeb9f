#pragma once
// Front-to-back alpha compositing of depth-sorted, tile-binned splats (forward) and its exact backward,
// parallel over 16×16 tiles. Plain loops over raw arrays; images are channel-major [C, H, W].
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "lrf/splat/raster/projection.h"

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
  const float* colors = nullptr;      // [N,C] (backward; the forward takes a ColorSource)
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

// Colours evaluated on first use: most Gaussians of a dense field lie behind saturated pixels and never need
// theirs (at 63×47 px with 50k Gaussians, ~80%). state[g]: 0 not evaluated, 1 being evaluated, 2 ready.
struct ColorSource {
  float* colors;    // [N,C]
  uint8_t* state;   // [N], zeros on entry
  void (*evaluate)(const void* ctx, int64_t g, float* out);
  const void* ctx;
  // Where evaluate reads Gaussian g's inputs: row_bytes at rows + g·row_stride (its SH coefficients) and
  // 12 bytes at point + 3g (its mean). The tile loop prefetches them a few entries ahead for colours not
  // yet evaluated: a first evaluation otherwise waits on cache misses in a field larger than the cache.
  const char* rows = nullptr;
  int64_t row_stride = 0, row_bytes = 0;
  const float* point = nullptr;

  void prefetch(int64_t g) const {
    if (!rows || __atomic_load_n(state + g, __ATOMIC_RELAXED) == 2) return;
    const char* row = rows + g * row_stride;
    for (int64_t b = 0; b < row_bytes; b += 64) __builtin_prefetch(row + b);
    __builtin_prefetch(row + row_bytes - 1);
    __builtin_prefetch(point + 3 * g);
  }

  const float* get(int64_t g, int C) const {
    float* out = colors + g * C;
    if (__atomic_load_n(state + g, __ATOMIC_ACQUIRE) == 2) return out;
    uint8_t expected = 0;
    if (__atomic_compare_exchange_n(state + g, &expected, uint8_t{1}, false, __ATOMIC_ACQ_REL, __ATOMIC_ACQUIRE)) {
      evaluate(ctx, g, out);
      __atomic_store_n(state + g, uint8_t{2}, __ATOMIC_RELEASE);
    } else {
      while (__atomic_load_n(state + g, __ATOMIC_ACQUIRE) != 2) {  // another thread is evaluating it
      }
    }
    return out;
  }
};

void rasterize_forward(const RasterInputs& in, const ColorSource& colors, const RasterForwardOutputs& out);

struct RasterBackwardInputs {
  const float* t_final;  // [H,W]
  const int32_t* last;   // [H,W]
  const float* d_image;  // [C,H,W]
  const float* d_alpha;  // [H,W] or nullptr (no gradient)
  const float* d_depth;  // [H,W] or nullptr
};

// Gradients per Gaussian; all overwritten (zeros for Gaussians that touch no pixel), except that with
// colors_only_touched the colour rows of those Gaussians are left as they are: at 63×47 px with 50k
// Gaussians that saves writing ~80% of a [N, 32] array nobody reads (sh_backward skips Gaussians whose
// colour the forward never evaluated, and those are exactly the ones the backward does not touch).
struct RasterGrads {
  float* xy;       // [N,2] pixel units
  float* conic;    // [N,3]
  float* opacity;  // [N]
  float* depth;    // [N] (from the depth output)
  float* colors;   // [N,C]
  bool colors_only_touched = false;
};

void rasterize_backward(int64_t n, const RasterInputs& in, const RasterBackwardInputs& bin, const RasterGrads& out);

// The kernels run several pixels of a row at a time: 8 (AVX2) where the CPU has it, else 4 (SSE2; 1 off
// x86-64).
// Every lane computes the same bits at any width, so the images agree exactly; gradient sums over lanes are
// added in a different order, so gradients agree to float rounding. Tests set the width to cover each.
int raster_vector_width();
// Chooses a width the CPU supports (8 with AVX2, 4 on x86-64, and 1 anywhere); returns false, changing
// nothing, for any other.
bool set_raster_vector_width(int width);

// Tile lists visit Gaussians in depth order, i.e. at random places of the per-Gaussian arrays: ask for the
// data of the entry a few steps ahead so that its cache misses overlap with the current entry's work.
inline void prefetch_splat(const RasterInputs& in, int32_t g) {
  __builtin_prefetch(in.xy + 2 * g);
  __builtin_prefetch(in.extent + 2 * g);
  __builtin_prefetch(in.conic + 3 * g);
  __builtin_prefetch(in.opacity + g);
}
constexpr int kPrefetchDistance = 8;

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
