#pragma once
// Front-to-back alpha compositing of depth-sorted, tile-binned splats (forward) and its exact backward,
// parallel over 16×16 tiles. Plain loops over raw arrays; images are channel-major [C, H, W].
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

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

// e^x for x <= 0 (Cephes-style: x = n·ln2 + r, degree-6 polynomial in r, 2^n through the exponent bits;
// ~2 ulp). Plain IEEE arithmetic in a fixed order: the SSE2 version below gives the same bits.
inline float exp_nonpositive(float x) {
  x = x < -87.f ? -87.f : x;
  const int32_t n = static_cast<int32_t>(x * 1.44269504088896341f - 0.5f);  // round to nearest for x <= 0
  const float fn = static_cast<float>(n);
  const float r = (x - fn * 0.693359375f) + fn * 2.12194440e-4f;
  float p = 1.9875691500e-4f;
  p = p * r + 1.3981999507e-3f;
  p = p * r + 8.3334519073e-3f;
  p = p * r + 4.1665795894e-2f;
  p = p * r + 1.6666665459e-1f;
  p = p * r + 5.0000001201e-1f;
  p = p * r * r + r + 1.f;
  const int32_t bits = (n + 127) << 23;
  float scale;
  std::memcpy(&scale, &bits, sizeof(scale));
  return p * scale;
}

#if defined(__SSE2__)
inline __m128 exp_nonpositive(__m128 x) {
  x = _mm_max_ps(x, _mm_set1_ps(-87.f));
  const __m128i n = _mm_cvttps_epi32(_mm_sub_ps(_mm_mul_ps(x, _mm_set1_ps(1.44269504088896341f)), _mm_set1_ps(0.5f)));
  const __m128 fn = _mm_cvtepi32_ps(n);
  const __m128 r = _mm_add_ps(_mm_sub_ps(x, _mm_mul_ps(fn, _mm_set1_ps(0.693359375f))),
                              _mm_mul_ps(fn, _mm_set1_ps(2.12194440e-4f)));
  __m128 p = _mm_set1_ps(1.9875691500e-4f);
  p = _mm_add_ps(_mm_mul_ps(p, r), _mm_set1_ps(1.3981999507e-3f));
  p = _mm_add_ps(_mm_mul_ps(p, r), _mm_set1_ps(8.3334519073e-3f));
  p = _mm_add_ps(_mm_mul_ps(p, r), _mm_set1_ps(4.1665795894e-2f));
  p = _mm_add_ps(_mm_mul_ps(p, r), _mm_set1_ps(1.6666665459e-1f));
  p = _mm_add_ps(_mm_mul_ps(p, r), _mm_set1_ps(5.0000001201e-1f));
  p = _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_mul_ps(p, r), r), r), _mm_set1_ps(1.f));
  const __m128 scale = _mm_castsi128_ps(_mm_slli_epi32(_mm_add_epi32(n, _mm_set1_epi32(127)), 23));
  return _mm_mul_ps(p, scale);
}
#endif

// α and e^−σ of a splat along one pixel row of at most kTileSize pixels: pixel k is at offset
// (dx0 − k, dy) = mean − pixel centre. α is 0 where the splat is skipped (σ < 0 from rounding, or
// α < 1/255). Forward and backward both call this function, so that they take the same decisions bit for
// bit. alpha and gauss must hold kTileSize floats (whole SIMD groups are written).
inline void splat_alpha_row(float A, float B, float C, float o, float dx0, float dy, int len, float* alpha,
                            float* gauss) {
  const float a2 = -0.5f * A, by = -B * dy, cy = -0.5f * C * dy * dy;
#if defined(__SSE2__)
  const __m128 va2 = _mm_set1_ps(a2), vby = _mm_set1_ps(by), vcy = _mm_set1_ps(cy), vo = _mm_set1_ps(o);
  const __m128 vdx0 = _mm_set1_ps(dx0), ramp = _mm_setr_ps(0.f, 1.f, 2.f, 3.f);
  for (int k = 0; k < len; k += 4) {
    const __m128 dx = _mm_sub_ps(vdx0, _mm_add_ps(_mm_set1_ps(static_cast<float>(k)), ramp));
    const __m128 power = _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_mul_ps(va2, dx), dx), _mm_mul_ps(vby, dx)), vcy);
    const __m128 g = exp_nonpositive(power);
    const __m128 og = _mm_mul_ps(vo, g);
    const __m128 a = _mm_min_ps(_mm_set1_ps(kMaxAlpha), og);
    const __m128 keep = _mm_and_ps(_mm_cmple_ps(power, _mm_setzero_ps()), _mm_cmpge_ps(a, _mm_set1_ps(kMinAlpha)));
    _mm_storeu_ps(alpha + k, _mm_and_ps(keep, a));
    _mm_storeu_ps(gauss + k, g);
  }
#else
  for (int k = 0; k < len; ++k) {
    const float dx = dx0 - static_cast<float>(k);
    const float power = a2 * dx * dx + by * dx + cy;
    const float g = exp_nonpositive(power);
    const float a = std::min(kMaxAlpha, o * g);
    alpha[k] = (power <= 0.f && a >= kMinAlpha) ? a : 0.f;
    gauss[k] = g;
  }
#endif
}

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
