#include <omp.h>

#include <vector>

#include "lrf/splat/raster_kernels.h"

namespace lrf::splat {
namespace {

constexpr int kTilePixels = kTileSize * kTileSize;
constexpr int kGeomGrads = 7;  // d xy (2), d conic (3), d opacity, d depth

// Where one thread accumulates: per-Gaussian geometry gradients [N,7] and colour gradients [N,C].
struct GradBuffer {
  float* geom;
  float* colors;
};

// One tile, walking its list back to front. For pixel colour P = Σ_k c_k α_k T_k + T_final·bg:
//   ∂P/∂α_i = c_i·T_i − (R_i + T_final·bg)/(1 − α_i),   R_i = Σ_{k>i} c_k α_k T_k,
// where T_i = T_{i+1}/(1 − α_i) is recovered from T_final. Only the scalar R·g is needed per pixel (g the
// upstream gradient), so the state per pixel is a few floats whatever C is. alpha = 1 − T_final gives
// ∂/∂α_i = T_final/(1 − α_i); depth is one more channel with colour z.
template <int kC>
void backward_tile(int tile, const RasterInputs& in, const RasterBackwardInputs& bin, GradBuffer buf,
                   float* grad_pixels, float* dcol) {
  const int C = kC > 0 ? kC : in.channels;
  const int x0 = (tile % in.tiles_x) * kTileSize, y0 = (tile / in.tiles_x) * kTileSize;
  const int x1 = std::min(x0 + kTileSize, in.width), y1 = std::min(y0 + kTileSize, in.height);
  const int w = x1 - x0, npix = w * (y1 - y0);
  const int64_t plane = static_cast<int64_t>(in.width) * in.height;
  float T[kTilePixels], Tf[kTilePixels], RG[kTilePixels], RD[kTilePixels], bg_g[kTilePixels];
  float g_alpha[kTilePixels], g_depth[kTilePixels];
  int32_t last[kTilePixels];
  int32_t max_last = -1;
  for (int p = 0; p < npix; ++p) {
    const int64_t pix = static_cast<int64_t>(y0 + p / w) * in.width + x0 + p % w;
    T[p] = Tf[p] = bin.t_final[pix];
    RG[p] = RD[p] = 0;
    float dot = 0;
    for (int c = 0; c < C; ++c) {
      const float g = bin.d_image[c * plane + pix];
      grad_pixels[p * C + c] = g;
      dot += g * in.background[c];
    }
    bg_g[p] = dot;
    g_alpha[p] = bin.d_alpha ? bin.d_alpha[pix] : 0.f;
    g_depth[p] = bin.d_depth ? bin.d_depth[pix] : 0.f;
    last[p] = bin.last[pix];
    max_last = std::max(max_last, last[p]);
  }

  const int32_t begin = in.tile_offsets[tile];
  for (int32_t k = begin + max_last; k >= begin; --k) {
    const int32_t g = in.tile_ids[k];
    const int32_t pos = k - begin;
    const float gx = in.xy[2 * g], gy = in.xy[2 * g + 1];
    const PixelSpan span = splat_span(gx, gy, in.extent[2 * g], in.extent[2 * g + 1], x0, y0, x1, y1);
    if (span.empty()) continue;
    const float A = in.conic[3 * g], B = in.conic[3 * g + 1], Cc = in.conic[3 * g + 2];
    const float o = in.opacity[g], z = in.depth[g];
    const float* col = in.colors + static_cast<int64_t>(g) * C;
    float d_gx = 0, d_gy = 0, dA = 0, dB = 0, dC = 0, d_o = 0, d_z = 0;
    bool touched = false;
    float row_alpha[kTileSize], row_gauss[kTileSize];
    const int len = span.j1 - span.j0;
    for (int i = span.i0; i < span.i1; ++i) {
      const float dy = gy - (i + 0.5f), dx0 = gx - (span.j0 + 0.5f);
      splat_alpha_row(A, B, Cc, o, dx0, dy, len, row_alpha, row_gauss);
      const int row = (i - y0) * w + (span.j0 - x0);
      for (int kk = 0; kk < len; ++kk) {
        const float alpha = row_alpha[kk];
        const int p = row + kk;
        if (alpha == 0.f || pos > last[p]) continue;
        const float gauss = row_gauss[kk];
        const float dx = dx0 - static_cast<float>(kk);
        if (!touched) {
          std::fill(dcol, dcol + C, 0.f);
          touched = true;
        }
        const float inv = 1.f / (1.f - alpha);
        const float Ti = T[p] * inv;
        const float weight = alpha * Ti;
        const float* gp = grad_pixels + p * C;
        float cg = 0;
        for (int c = 0; c < C; ++c) {
          cg += col[c] * gp[c];
          dcol[c] += weight * gp[c];
        }
        const float d_alpha = Ti * cg - (RG[p] + Tf[p] * bg_g[p]) * inv + g_alpha[p] * Tf[p] * inv +
                              g_depth[p] * (z * Ti - RD[p] * inv);
        d_z += g_depth[p] * weight;
        RG[p] += cg * weight;
        RD[p] += z * weight;
        T[p] = Ti;
        if (o * gauss <= kMaxAlpha) {  // α = o·e^power; where clamped at 0.99 it does not move
          d_o += gauss * d_alpha;
          const float d_power = d_alpha * alpha;
          d_gx -= d_power * (A * dx + B * dy);
          d_gy -= d_power * (Cc * dy + B * dx);
          dA -= d_power * 0.5f * dx * dx;
          dB -= d_power * dx * dy;
          dC -= d_power * 0.5f * dy * dy;
        }
      }
    }
    if (!touched) continue;
    float* geom = buf.geom + static_cast<int64_t>(g) * kGeomGrads;
    geom[0] += d_gx;
    geom[1] += d_gy;
    geom[2] += dA;
    geom[3] += dB;
    geom[4] += dC;
    geom[5] += d_o;
    geom[6] += d_z;
    float* gc = buf.colors + static_cast<int64_t>(g) * C;
    for (int c = 0; c < C; ++c) gc[c] += dcol[c];
  }
}

template <int kC>
void backward_impl(int64_t n, const RasterInputs& in, const RasterBackwardInputs& bin, const RasterGrads& out) {
  const int C = in.channels;
  const int tiles = in.tiles_x * in.tiles_y;
  const int threads = std::max(1, std::min(omp_get_max_threads(), tiles));
  // Thread 0 accumulates into the first buffer set, others into private ones, reduced at the end: no atomics
  // in the hot loop. The geometry buffer is interleaved per Gaussian for locality.
  std::vector<std::vector<float>> geom(threads), colors(threads);
  for (int t = 0; t < threads; ++t) {
    geom[t].assign(static_cast<size_t>(n) * kGeomGrads, 0.f);
    if (t > 0) colors[t].assign(static_cast<size_t>(n) * C, 0.f);
  }
  std::fill(out.colors, out.colors + n * C, 0.f);
#pragma omp parallel num_threads(threads)
  {
    const int t = omp_get_thread_num();
    GradBuffer buf{geom[t].data(), t == 0 ? out.colors : colors[t].data()};
    std::vector<float> grad_pixels(static_cast<size_t>(kTilePixels) * C), dcol(C);
#pragma omp for schedule(dynamic)
    for (int tile = 0; tile < tiles; ++tile) backward_tile<kC>(tile, in, bin, buf, grad_pixels.data(), dcol.data());
  }
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    float sum[kGeomGrads];
    for (int k = 0; k < kGeomGrads; ++k) sum[k] = geom[0][i * kGeomGrads + k];
    for (int t = 1; t < threads; ++t) {
      for (int k = 0; k < kGeomGrads; ++k) sum[k] += geom[t][i * kGeomGrads + k];
      for (int c = 0; c < C; ++c) out.colors[i * C + c] += colors[t][i * C + c];
    }
    out.xy[2 * i] = sum[0];
    out.xy[2 * i + 1] = sum[1];
    out.conic[3 * i] = sum[2];
    out.conic[3 * i + 1] = sum[3];
    out.conic[3 * i + 2] = sum[4];
    out.opacity[i] = sum[5];
    out.depth[i] = sum[6];
  }
}

}  // namespace

void rasterize_backward(int64_t n, const RasterInputs& in, const RasterBackwardInputs& bin, const RasterGrads& out) {
  switch (in.channels) {
    case 1: backward_impl<1>(n, in, bin, out); break;
    case 3: backward_impl<3>(n, in, bin, out); break;
    case 4: backward_impl<4>(n, in, bin, out); break;
    case 16: backward_impl<16>(n, in, bin, out); break;
    case 32: backward_impl<32>(n, in, bin, out); break;
    default: backward_impl<0>(n, in, bin, out); break;
  }
}

}  // namespace lrf::splat
