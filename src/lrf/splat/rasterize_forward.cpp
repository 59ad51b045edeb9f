#include <omp.h>

#include <vector>

#include "lrf/splat/raster_kernels.h"

namespace lrf::splat {
namespace {

constexpr int kTilePixels = kTileSize * kTileSize;

// One tile. Splats are visited in depth order and each one only over the pixels of its α box, which gives
// exactly the per-pixel front-to-back result (each pixel sees the same splats in the same order) at a
// cost proportional to the splats' footprints rather than list length × 256.
template <int kC>
void forward_tile(int tile, const RasterInputs& in, const RasterForwardOutputs& out, float* acc) {
  const int C = kC > 0 ? kC : in.channels;
  const int x0 = (tile % in.tiles_x) * kTileSize, y0 = (tile / in.tiles_x) * kTileSize;
  const int x1 = std::min(x0 + kTileSize, in.width), y1 = std::min(y0 + kTileSize, in.height);
  const int w = x1 - x0, npix = w * (y1 - y0);
  float T[kTilePixels], acc_depth[kTilePixels];
  int32_t last[kTilePixels];
  bool done[kTilePixels];
  std::fill(T, T + npix, 1.f);
  std::fill(acc_depth, acc_depth + npix, 0.f);
  std::fill(last, last + npix, -1);
  std::fill(done, done + npix, false);
  std::fill(acc, acc + npix * C, 0.f);
  int remaining = npix;

  const int32_t begin = in.tile_offsets[tile], end = in.tile_offsets[tile + 1];
  for (int32_t k0 = begin; k0 < end && remaining > 0; ++k0) {
    const int32_t g = in.tile_ids[k0];
    const float gx = in.xy[2 * g], gy = in.xy[2 * g + 1];
    const PixelSpan span = splat_span(gx, gy, in.extent[2 * g], in.extent[2 * g + 1], x0, y0, x1, y1);
    if (span.empty()) continue;
    const float A = in.conic[3 * g], B = in.conic[3 * g + 1], Cc = in.conic[3 * g + 2];
    const float o = in.opacity[g], z = in.depth[g];
    const float* col = in.colors + static_cast<int64_t>(g) * C;
    float row_alpha[kTileSize], row_gauss[kTileSize];
    const int len = span.j1 - span.j0;
    for (int i = span.i0; i < span.i1; ++i) {
      splat_alpha_row(A, B, Cc, o, gx - (span.j0 + 0.5f), gy - (i + 0.5f), len, row_alpha, row_gauss);
      const int row = (i - y0) * w + (span.j0 - x0);
      for (int k = 0; k < len; ++k) {
        const float alpha = row_alpha[k];
        const int p = row + k;
        if (alpha == 0.f || done[p]) continue;
        const float next_T = T[p] * (1.f - alpha);
        if (next_T < kMinTransmittance) {
          done[p] = true;
          --remaining;
          continue;
        }
        const float weight = alpha * T[p];
        float* a = acc + p * C;
        for (int c = 0; c < C; ++c) a[c] += col[c] * weight;
        acc_depth[p] += z * weight;
        T[p] = next_T;
        last[p] = k0 - begin;
      }
    }
  }

  const int64_t plane = static_cast<int64_t>(in.width) * in.height;
  for (int p = 0; p < npix; ++p) {
    const int64_t pix = static_cast<int64_t>(y0 + p / w) * in.width + x0 + p % w;
    for (int c = 0; c < C; ++c) out.image[c * plane + pix] = acc[p * C + c] + T[p] * in.background[c];
    out.alpha[pix] = 1.f - T[p];
    out.depth[pix] = acc_depth[p];
    out.t_final[pix] = T[p];
    out.last[pix] = last[p];
  }
}

template <int kC>
void forward_impl(const RasterInputs& in, const RasterForwardOutputs& out) {
  const int tiles = in.tiles_x * in.tiles_y;
#pragma omp parallel
  {
    std::vector<float> acc(static_cast<size_t>(kTilePixels) * in.channels);
#pragma omp for schedule(dynamic)
    for (int t = 0; t < tiles; ++t) forward_tile<kC>(t, in, out, acc.data());
  }
}

}  // namespace

void rasterize_forward(const RasterInputs& in, const RasterForwardOutputs& out) {
  switch (in.channels) {
    case 1: forward_impl<1>(in, out); break;
    case 3: forward_impl<3>(in, out); break;
    case 4: forward_impl<4>(in, out); break;
    case 16: forward_impl<16>(in, out); break;
    case 32: forward_impl<32>(in, out); break;
    default: forward_impl<0>(in, out); break;
  }
}

}  // namespace lrf::splat
