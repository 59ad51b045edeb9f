#include <omp.h>

#include <vector>

#include "lrf/splat/raster_kernels.h"

namespace lrf::splat {
namespace {

// Tile-local state is indexed p = row·kTileSize + column whatever the tile's clipped width, so that groups
// of 4 pixels never straddle two rows.
constexpr int kTilePixels = kTileSize * kTileSize;
// Per-pixel arrays get 4 spare floats: a group of 4 lanes starting at the last pixels of a row may reach up
// to 3 past the tile (those lanes are masked, but they are loaded and stored back unchanged).
constexpr int kTileStorage = kTilePixels + 4;

// One tile. Splats are visited in depth order and each one only over the pixels of its α box, which gives
// exactly the per-pixel front-to-back result (each pixel sees the same splats in the same order) at a cost
// proportional to the splats' footprints rather than list length × 256. Colour accumulators are
// channel-major (acc[c·256 + p]) so that 4 neighbouring pixels update together.
template <int kC>
void forward_tile(int tile, const RasterInputs& in, const ColorSource& source, const RasterForwardOutputs& out,
                  float* acc) {
  const int C = kC > 0 ? kC : in.channels;
  const int x0 = (tile % in.tiles_x) * kTileSize, y0 = (tile / in.tiles_x) * kTileSize;
  const int x1 = std::min(x0 + kTileSize, in.width), y1 = std::min(y0 + kTileSize, in.height);
  alignas(16) float T[kTileStorage], acc_depth[kTileStorage];
  alignas(16) int32_t last[kTileStorage], done[kTileStorage];  // done: all ones once the pixel is saturated
  std::fill(T, T + kTileStorage, 1.f);
  std::fill(acc_depth, acc_depth + kTileStorage, 0.f);
  std::fill(last, last + kTileStorage, -1);
  std::fill(done, done + kTileStorage, 0);
  std::fill(acc, acc + kTileStorage * C, 0.f);
  int remaining = (x1 - x0) * (y1 - y0);

  const int32_t begin = in.tile_offsets[tile], end = in.tile_offsets[tile + 1];
  for (int32_t k = begin; k < end && remaining > 0; ++k) {
    const int32_t g = in.tile_ids[k];
    const int32_t pos = k - begin;
    if (k + kPrefetchDistance < end) prefetch_splat(in, in.tile_ids[k + kPrefetchDistance]);
    const float gx = in.xy[2 * g], gy = in.xy[2 * g + 1];
    const PixelSpan span = splat_span(gx, gy, in.extent[2 * g], in.extent[2 * g + 1], x0, y0, x1, y1);
    if (span.empty()) continue;
    const float A = in.conic[3 * g], B = in.conic[3 * g + 1], Cc = in.conic[3 * g + 2];
    const float o = in.opacity[g], z = in.depth[g];
    const float* col = nullptr;  // evaluated when the splat is first blended
    alignas(16) float row_alpha[kTileSize], row_gauss[kTileSize];
    const int len = span.j1 - span.j0;
    for (int i = span.i0; i < span.i1; ++i) {
      splat_alpha_row(A, B, Cc, o, gx - (span.j0 + 0.5f), gy - (i + 0.5f), len, row_alpha, row_gauss);
      const int row = (i - y0) * kTileSize + (span.j0 - x0);
#if defined(__SSE2__)
      const __m128 one = _mm_set1_ps(1.f), min_T = _mm_set1_ps(kMinTransmittance), vz = _mm_set1_ps(z);
      const __m128i vpos = _mm_set1_epi32(pos);
      for (int q = 0; q < len; q += 4) {
        const int p = row + q;
        // Lanes past the span, already saturated, or skipped by α are neutral: α = 0 changes nothing.
        const __m128i in_span = _mm_cmplt_epi32(_mm_add_epi32(_mm_set1_epi32(q), _mm_setr_epi32(0, 1, 2, 3)),
                                                _mm_set1_epi32(len));
        const __m128i dn = _mm_loadu_si128(reinterpret_cast<const __m128i*>(done + p));
        const __m128 live = _mm_castsi128_ps(_mm_andnot_si128(dn, in_span));
        const __m128 alpha = _mm_and_ps(_mm_loadu_ps(row_alpha + q), live);
        const __m128 t = _mm_loadu_ps(T + p);
        const __m128 next_T = _mm_mul_ps(t, _mm_sub_ps(one, alpha));
        const __m128 hit = _mm_cmpneq_ps(alpha, _mm_setzero_ps());
        const __m128 stop = _mm_and_ps(hit, _mm_cmplt_ps(next_T, min_T));
        const int stop_bits = _mm_movemask_ps(stop);
        if (stop_bits) {
          _mm_storeu_si128(reinterpret_cast<__m128i*>(done + p), _mm_or_si128(dn, _mm_castps_si128(stop)));
          remaining -= __builtin_popcount(stop_bits);
        }
        const __m128 blend = _mm_andnot_ps(stop, hit);
        if (!_mm_movemask_ps(blend)) continue;
        if (!col) col = source.get(g, C);
        const __m128 a = _mm_and_ps(alpha, blend);
        const __m128 weight = _mm_mul_ps(a, t);
        for (int c = 0; c < C; ++c) {
          float* dst = acc + c * kTileStorage + p;
          _mm_storeu_ps(dst, _mm_add_ps(_mm_loadu_ps(dst), _mm_mul_ps(_mm_set1_ps(col[c]), weight)));
        }
        _mm_storeu_ps(acc_depth + p, _mm_add_ps(_mm_loadu_ps(acc_depth + p), _mm_mul_ps(vz, weight)));
        // T·(1 − 0) = T on the other lanes, bit for bit.
        _mm_storeu_ps(T + p, _mm_mul_ps(t, _mm_sub_ps(one, a)));
        const __m128i bl = _mm_castps_si128(blend);
        const __m128i old_last = _mm_loadu_si128(reinterpret_cast<const __m128i*>(last + p));
        _mm_storeu_si128(reinterpret_cast<__m128i*>(last + p),
                         _mm_or_si128(_mm_and_si128(bl, vpos), _mm_andnot_si128(bl, old_last)));
      }
#else
      for (int q = 0; q < len; ++q) {
        const float alpha = row_alpha[q];
        const int p = row + q;
        if (alpha == 0.f || done[p]) continue;
        const float next_T = T[p] * (1.f - alpha);
        if (next_T < kMinTransmittance) {
          done[p] = -1;
          --remaining;
          continue;
        }
        if (!col) col = source.get(g, C);
        const float weight = alpha * T[p];
        for (int c = 0; c < C; ++c) acc[c * kTileStorage + p] += col[c] * weight;
        acc_depth[p] += z * weight;
        T[p] = next_T;
        last[p] = pos;
      }
#endif
    }
  }

  const int64_t plane = static_cast<int64_t>(in.width) * in.height;
  for (int i = y0; i < y1; ++i)
    for (int j = x0; j < x1; ++j) {
      const int p = (i - y0) * kTileSize + (j - x0);
      const int64_t pix = static_cast<int64_t>(i) * in.width + j;
      for (int c = 0; c < C; ++c) out.image[c * plane + pix] = acc[c * kTileStorage + p] + T[p] * in.background[c];
      out.alpha[pix] = 1.f - T[p];
      out.depth[pix] = acc_depth[p];
      out.t_final[pix] = T[p];
      out.last[pix] = last[p];
    }
}

template <int kC>
void forward_impl(const RasterInputs& in, const ColorSource& source, const RasterForwardOutputs& out) {
  const int tiles = in.tiles_x * in.tiles_y;
#pragma omp parallel
  {
    std::vector<float> acc(static_cast<size_t>(kTileStorage) * in.channels);
#pragma omp for schedule(dynamic)
    for (int t = 0; t < tiles; ++t) forward_tile<kC>(t, in, source, out, acc.data());
  }
}

}  // namespace

void rasterize_forward(const RasterInputs& in, const ColorSource& source, const RasterForwardOutputs& out) {
  switch (in.channels) {
    case 1: forward_impl<1>(in, source, out); break;
    case 3: forward_impl<3>(in, source, out); break;
    case 4: forward_impl<4>(in, source, out); break;
    case 16: forward_impl<16>(in, source, out); break;
    case 32: forward_impl<32>(in, source, out); break;
    default: forward_impl<0>(in, source, out); break;
  }
}

}  // namespace lrf::splat
