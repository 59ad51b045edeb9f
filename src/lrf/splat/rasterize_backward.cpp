#include <omp.h>

#include <cstdint>
#include <vector>

#include "lrf/splat/raster_kernels.h"

namespace lrf::splat {
namespace {

constexpr int kTilePixels = kTileSize * kTileSize;
// Per-pixel arrays get 4 spare floats: a group of 4 lanes starting at the last pixels of a row may reach up
// to 3 past the tile (those lanes are masked, but they are loaded and stored back unchanged).
constexpr int kTileStorage = kTilePixels + 4;
constexpr int kGeomGrads = 7;  // d xy (2), d conic (3), d opacity, d depth

// Where one thread accumulates: per-Gaussian geometry gradients [N,7] and colour gradients [N,C]. A slot
// is written (not added) the first time the thread touches that Gaussian, so the buffers never need zeroing.
struct GradBuffer {
  float* geom;
  float* colors;
  uint8_t* touched;
};

// The buffers live with the calling thread and are reused by the next call: allocating tens of MB per
// iteration costs page faults comparable to the work itself.
struct ThreadGrads {
  std::vector<float> geom, colors;
  std::vector<uint8_t> touched;
};

#if defined(__SSE2__)
inline float hsum(__m128 v) {
  const __m128 s = _mm_add_ps(v, _mm_movehl_ps(v, v));
  return _mm_cvtss_f32(_mm_add_ss(s, _mm_shuffle_ps(s, s, 1)));
}
#endif

// Per-pixel state of one tile, indexed p = row·kTileSize + column (as in the forward).
struct TileState {
  alignas(16) float T[kTileStorage];     // transmittance in front of the splat being processed
  alignas(16) float RG[kTileStorage];    // R·g: upstream-weighted colour of the splats behind it
  alignas(16) float RD[kTileStorage];    // the same for depth
  alignas(16) float bgT[kTileStorage];   // T_final·(bg·g)
  alignas(16) float gaT[kTileStorage];   // T_final·(d loss / d alpha)
  alignas(16) float gd[kTileStorage];    // d loss / d depth
  alignas(16) int32_t last[kTileStorage];
};

template <int kC>
void backward_tile(int tile, const RasterInputs& in, const RasterBackwardInputs& bin, GradBuffer buf,
                   float* grad_pixels, float* dcol) {
  const int C = kC > 0 ? kC : in.channels;
  const int x0 = (tile % in.tiles_x) * kTileSize, y0 = (tile / in.tiles_x) * kTileSize;
  const int x1 = std::min(x0 + kTileSize, in.width), y1 = std::min(y0 + kTileSize, in.height);
  const int64_t plane = static_cast<int64_t>(in.width) * in.height;
  TileState st;
  // Pixels outside the image stay neutral: never live (last = −1), zero gradients.
  std::fill(st.T, st.T + kTileStorage, 1.f);
  std::fill(st.RG, st.RG + kTileStorage, 0.f);
  std::fill(st.RD, st.RD + kTileStorage, 0.f);
  std::fill(st.bgT, st.bgT + kTileStorage, 0.f);
  std::fill(st.gaT, st.gaT + kTileStorage, 0.f);
  std::fill(st.gd, st.gd + kTileStorage, 0.f);
  std::fill(st.last, st.last + kTileStorage, -1);
  std::fill(grad_pixels, grad_pixels + kTileStorage * C, 0.f);  // channel-major, [c·256 + p]
  int32_t max_last = -1;
  for (int i = y0; i < y1; ++i)
    for (int j = x0; j < x1; ++j) {
      const int p = (i - y0) * kTileSize + (j - x0);
      const int64_t pix = static_cast<int64_t>(i) * in.width + j;
      const float tf = bin.t_final[pix];
      st.T[p] = tf;
      float dot = 0;
      for (int c = 0; c < C; ++c) {
        const float g = bin.d_image[c * plane + pix];
        grad_pixels[c * kTileStorage + p] = g;
        dot += g * in.background[c];
      }
      st.bgT[p] = tf * dot;
      st.gaT[p] = bin.d_alpha ? tf * bin.d_alpha[pix] : 0.f;
      st.gd[p] = bin.d_depth ? bin.d_depth[pix] : 0.f;
      st.last[p] = bin.last[pix];
      max_last = std::max(max_last, st.last[p]);
    }

  const int32_t begin = in.tile_offsets[tile];
  for (int32_t k = begin + max_last; k >= begin; --k) {
    const int32_t g = in.tile_ids[k];
    const int32_t pos = k - begin;
    if (k - kPrefetchDistance >= begin) prefetch_splat(in, in.tile_ids[k - kPrefetchDistance]);
    const float gx = in.xy[2 * g], gy = in.xy[2 * g + 1];
    const PixelSpan span = splat_span(gx, gy, in.extent[2 * g], in.extent[2 * g + 1], x0, y0, x1, y1);
    if (span.empty()) continue;
    const float A = in.conic[3 * g], B = in.conic[3 * g + 1], Cc = in.conic[3 * g + 2];
    const float o = in.opacity[g], z = in.depth[g];
    const float* col = in.colors + static_cast<int64_t>(g) * C;
    alignas(16) float row_alpha[kTileSize], row_gauss[kTileSize];
    const int len = span.j1 - span.j0;
    bool touched = false;
#if defined(__SSE2__)
    // 4 pixels of a row at a time; lanes that do not take part carry α = 0, which leaves T, R·g and R·d
    // unchanged bit for bit, and their d loss / d α is masked out.
    __m128* dcolv = reinterpret_cast<__m128*>(dcol);
    __m128 v_gx = _mm_setzero_ps(), v_gy = _mm_setzero_ps(), v_A = _mm_setzero_ps(), v_B = _mm_setzero_ps();
    __m128 v_C = _mm_setzero_ps(), v_o = _mm_setzero_ps(), v_z = _mm_setzero_ps();
    const __m128 one = _mm_set1_ps(1.f), vz = _mm_set1_ps(z), vo = _mm_set1_ps(o), vA = _mm_set1_ps(A);
    const __m128 vB = _mm_set1_ps(B), vCc = _mm_set1_ps(Cc), half = _mm_set1_ps(0.5f), max_alpha = _mm_set1_ps(kMaxAlpha);
    const __m128i ramp = _mm_setr_epi32(0, 1, 2, 3), vpos = _mm_set1_epi32(pos), vlen = _mm_set1_epi32(len);
    for (int i = span.i0; i < span.i1; ++i) {
      const float dy = gy - (i + 0.5f), dx0 = gx - (span.j0 + 0.5f);
      splat_alpha_row(A, B, Cc, o, dx0, dy, len, row_alpha, row_gauss);
      const int row = (i - y0) * kTileSize + (span.j0 - x0);
      const __m128 vdy = _mm_set1_ps(dy), vdx0 = _mm_set1_ps(dx0);
      for (int q = 0; q < len; q += 4) {
        const int p = row + q;
        const __m128i lane = _mm_add_epi32(_mm_set1_epi32(q), ramp);
        const __m128i lst = _mm_loadu_si128(reinterpret_cast<const __m128i*>(st.last + p));
        // Live lanes: inside the span and not behind the pixel's last blended splat (pos <= last).
        const __m128i live = _mm_andnot_si128(_mm_cmpgt_epi32(vpos, lst), _mm_cmplt_epi32(lane, vlen));
        const __m128 alpha = _mm_and_ps(_mm_loadu_ps(row_alpha + q), _mm_castsi128_ps(live));
        const __m128 valid = _mm_cmpneq_ps(alpha, _mm_setzero_ps());
        if (!_mm_movemask_ps(valid)) continue;
        if (!touched) {
          for (int c = 0; c < C; ++c) dcolv[c] = _mm_setzero_ps();
          touched = true;
        }
        const __m128 gauss = _mm_loadu_ps(row_gauss + q);
        const __m128 inv = _mm_div_ps(one, _mm_sub_ps(one, alpha));
        const __m128 Ti = _mm_mul_ps(_mm_loadu_ps(st.T + p), inv);
        const __m128 weight = _mm_mul_ps(alpha, Ti);
        __m128 cg = _mm_setzero_ps();
        for (int c = 0; c < C; ++c) {
          const __m128 gp = _mm_loadu_ps(grad_pixels + c * kTileStorage + p);
          cg = _mm_add_ps(cg, _mm_mul_ps(_mm_set1_ps(col[c]), gp));
          dcolv[c] = _mm_add_ps(dcolv[c], _mm_mul_ps(weight, gp));
        }
        const __m128 rg = _mm_loadu_ps(st.RG + p), rd = _mm_loadu_ps(st.RD + p), gd = _mm_loadu_ps(st.gd + p);
        __m128 d_alpha = _mm_sub_ps(_mm_mul_ps(Ti, cg), _mm_mul_ps(_mm_add_ps(rg, _mm_loadu_ps(st.bgT + p)), inv));
        d_alpha = _mm_add_ps(d_alpha, _mm_mul_ps(_mm_loadu_ps(st.gaT + p), inv));
        d_alpha = _mm_add_ps(d_alpha, _mm_mul_ps(gd, _mm_sub_ps(_mm_mul_ps(vz, Ti), _mm_mul_ps(rd, inv))));
        v_z = _mm_add_ps(v_z, _mm_mul_ps(gd, weight));
        _mm_storeu_ps(st.RG + p, _mm_add_ps(rg, _mm_mul_ps(cg, weight)));
        _mm_storeu_ps(st.RD + p, _mm_add_ps(rd, _mm_mul_ps(vz, weight)));
        _mm_storeu_ps(st.T + p, Ti);
        // α = o·e^power moves with o and the shape only where it is not clamped at 0.99.
        const __m128 moving = _mm_and_ps(valid, _mm_cmple_ps(_mm_mul_ps(vo, gauss), max_alpha));
        const __m128 da = _mm_and_ps(d_alpha, moving);
        v_o = _mm_add_ps(v_o, _mm_mul_ps(gauss, da));
        const __m128 d_power = _mm_mul_ps(da, alpha);
        const __m128 dx = _mm_sub_ps(vdx0, _mm_cvtepi32_ps(lane));
        v_gx = _mm_sub_ps(v_gx, _mm_mul_ps(d_power, _mm_add_ps(_mm_mul_ps(vA, dx), _mm_mul_ps(vB, vdy))));
        v_gy = _mm_sub_ps(v_gy, _mm_mul_ps(d_power, _mm_add_ps(_mm_mul_ps(vCc, vdy), _mm_mul_ps(vB, dx))));
        v_A = _mm_sub_ps(v_A, _mm_mul_ps(_mm_mul_ps(d_power, half), _mm_mul_ps(dx, dx)));
        v_B = _mm_sub_ps(v_B, _mm_mul_ps(d_power, _mm_mul_ps(dx, vdy)));
        v_C = _mm_sub_ps(v_C, _mm_mul_ps(_mm_mul_ps(d_power, half), _mm_mul_ps(vdy, vdy)));
      }
    }
    if (!touched) continue;
    const float d_gx = hsum(v_gx), d_gy = hsum(v_gy), dA = hsum(v_A), dB = hsum(v_B), dC = hsum(v_C);
    const float d_o = hsum(v_o), d_z = hsum(v_z);
    for (int c = 0; c < C; ++c) dcol[4 * C + c] = hsum(dcolv[c]);
    const float* dcol_sum = dcol + 4 * C;
#else
    float d_gx = 0, d_gy = 0, dA = 0, dB = 0, dC = 0, d_o = 0, d_z = 0;
    for (int i = span.i0; i < span.i1; ++i) {
      const float dy = gy - (i + 0.5f), dx0 = gx - (span.j0 + 0.5f);
      splat_alpha_row(A, B, Cc, o, dx0, dy, len, row_alpha, row_gauss);
      const int row = (i - y0) * kTileSize + (span.j0 - x0);
      for (int q = 0; q < len; ++q) {
        const float alpha = row_alpha[q];
        const int p = row + q;
        if (alpha == 0.f || pos > st.last[p]) continue;
        const float gauss = row_gauss[q];
        const float dx = dx0 - static_cast<float>(q);
        if (!touched) {
          std::fill(dcol, dcol + C, 0.f);
          touched = true;
        }
        const float inv = 1.f / (1.f - alpha);
        const float Ti = st.T[p] * inv;
        const float weight = alpha * Ti;
        float cg = 0;
        for (int c = 0; c < C; ++c) {
          const float gp = grad_pixels[c * kTileStorage + p];
          cg += col[c] * gp;
          dcol[c] += weight * gp;
        }
        const float d_alpha = Ti * cg - (st.RG[p] + st.bgT[p]) * inv + st.gaT[p] * inv +
                              st.gd[p] * (z * Ti - st.RD[p] * inv);
        d_z += st.gd[p] * weight;
        st.RG[p] += cg * weight;
        st.RD[p] += z * weight;
        st.T[p] = Ti;
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
    const float* dcol_sum = dcol;
#endif
    float* geom = buf.geom + static_cast<int64_t>(g) * kGeomGrads;
    float* gc = buf.colors + static_cast<int64_t>(g) * C;
    const float sums[kGeomGrads] = {d_gx, d_gy, dA, dB, dC, d_o, d_z};
    if (!buf.touched[g]) {
      buf.touched[g] = 1;
      for (int m = 0; m < kGeomGrads; ++m) geom[m] = sums[m];
      for (int c = 0; c < C; ++c) gc[c] = dcol_sum[c];
    } else {
      for (int m = 0; m < kGeomGrads; ++m) geom[m] += sums[m];
      for (int c = 0; c < C; ++c) gc[c] += dcol_sum[c];
    }
  }
}

template <int kC>
void backward_impl(int64_t n, const RasterInputs& in, const RasterBackwardInputs& bin, const RasterGrads& out) {
  const int C = in.channels;
  const int tiles = in.tiles_x * in.tiles_y;
  const int threads = std::max(1, std::min(omp_get_max_threads(), tiles));
  // Each thread accumulates into its own buffers, reduced at the end: no atomics in the hot loop.
  // (A thread_local named inside the parallel regions would be each worker's own: bind it here.)
  thread_local std::vector<ThreadGrads> cache;
  std::vector<ThreadGrads>& scratch = cache;
  if (static_cast<int>(scratch.size()) < threads) scratch.resize(threads);
  for (int t = 0; t < threads; ++t) {
    scratch[t].geom.resize(static_cast<size_t>(n) * kGeomGrads);
    scratch[t].colors.resize(static_cast<size_t>(n) * C);
    scratch[t].touched.assign(n, 0);
  }
#pragma omp parallel num_threads(threads)
  {
    const int t = omp_get_thread_num();
    GradBuffer buf{scratch[t].geom.data(), scratch[t].colors.data(), scratch[t].touched.data()};
    // Scratch: the tile's upstream gradient (channel-major) and 4C + C floats of colour accumulators,
    // 16-byte aligned for the SIMD lanes.
    std::vector<float> grad_pixels(static_cast<size_t>(kTileStorage) * C), dcol_buf(5 * C + 4);
    float* dcol = dcol_buf.data();
    while (reinterpret_cast<uintptr_t>(dcol) % 16) ++dcol;
    // Tiles dealt round-robin, not dynamically: which thread's buffer a tile's gradients land in (and so
    // the rounding of the sums below) must not depend on timing, or two runs of one seed would differ
    // (and a run resumed from a checkpoint would not reach the uninterrupted run's result).
#pragma omp for schedule(static, 1)
    for (int tile = 0; tile < tiles; ++tile) backward_tile<kC>(tile, in, bin, buf, grad_pixels.data(), dcol);
  }
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    float sum[kGeomGrads] = {0, 0, 0, 0, 0, 0, 0};
    float* dc = out.colors + i * C;
    bool first = true;
    for (int t = 0; t < threads; ++t) {
      if (!scratch[t].touched[i]) continue;
      const float* geom = scratch[t].geom.data() + i * kGeomGrads;
      const float* col = scratch[t].colors.data() + i * C;
      for (int k = 0; k < kGeomGrads; ++k) sum[k] += geom[k];
      for (int c = 0; c < C; ++c) dc[c] = first ? col[c] : dc[c] + col[c];
      first = false;
    }
    if (first && !out.colors_only_touched) std::fill(dc, dc + C, 0.f);
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
