#pragma once
// The compositing kernels behind rasterize_forward / rasterize_backward, written once against the vector
// interface of simd.h and instantiated per width (raster_width_*.cpp). Plain loops over raw arrays;
// images are channel-major [C, H, W]; parallel over 16×16 tiles.
//
// Splats are visited in depth order and each one only over the pixels of its α box, which gives exactly
// the per-pixel front-to-back result (each pixel sees the same splats in the same order) at a cost
// proportional to the splats' footprints rather than list length × 256. Pixels go kWidth at a time along a
// row; lanes that do not take part carry α = 0, which leaves every per-pixel quantity unchanged bit for bit.
// A splat at most half a vector wide runs two rows per vector instead, half the lanes on each (most splats
// of a dense RGB field are that narrow: fern's 7k-step field at 504×378 spans 1-4 pixels in 70 % of its
// tile entries, so a row of 8 lanes carried 5.1 pixels on average). Each lane computes what it would on its
// own row, bit for bit.
//
// Many channels (latent fields, C = 16 or 32) change the layout of the per-channel work. At latent
// resolution a splat covers one to three pixels of a row, so a group of kWidth lanes blends about two of
// them (fern's 7k-step latent field: 2.05 of 8), and a channel loop over lanes would spend most of its
// C vector operations on masked lanes. There the tile's colour buffers are pixel-major ([p·C + c]) and
// each blended pixel runs its C channels kWidth at a time; the per-pixel scalars (α, T, depth) stay in
// lanes. Per channel the forward does the same multiply and add as the lane loop, so images do not change
// by a bit; the backward's sums over channels and pixels are taken in another order.
#include <omp.h>

#include <algorithm>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "lrf/splat/raster/raster_kernels.h"
#include "lrf/splat/raster/simd.h"

namespace lrf::splat::tiles {

// Tile-local state is indexed p = row·kTileSize + column whatever the tile's clipped width, so that a group
// of lanes never straddles two rows. Per-pixel arrays get spare floats: a group starting at the last pixels
// of a row may reach up to kWidth − 1 past the tile, and the second half of a pair of rows lies a row
// below the first, one past the tile's last row for a splat's odd last row (those lanes are masked, but
// they are loaded and stored back unchanged).
constexpr int kTilePixels = kTileSize * kTileSize;
constexpr int kTileStorage = kTilePixels + kTileSize + 8;

// Whether a width runs narrow spans two rows at a time (its vectors split in two halves).
template <class V>
constexpr bool row_pairs() {
  return V::kWidth >= 4;
}

// A group of lanes of tile state at x: one vector, or (paired) two halves a tile row apart.
template <class V, bool kPaired>
struct GroupAccess {
  using F = typename V::F;
  using I = typename V::I;
  static F load(const float* x) {
    if constexpr (kPaired) return V::load_halves(x, x + kTileSize);
    else return V::load(x);
  }
  static void store(float* x, F v) {
    if constexpr (kPaired) V::store_halves(x, x + kTileSize, v);
    else V::store(x, v);
  }
  static I loadi(const int32_t* x) {
    if constexpr (kPaired) return V::loadi_halves(x, x + kTileSize);
    else return V::loadi(x);
  }
  static void storei(int32_t* x, I v) {
    if constexpr (kPaired) V::storei_halves(x, x + kTileSize, v);
    else V::storei(x, v);
  }
  // The tile pixel of lane l of the group at p.
  static int pixel(int p, int l) {
    constexpr int kHalf = V::kWidth / 2;
    return kPaired && l >= kHalf ? p + kTileSize + l - kHalf : p + l;
  }
};

constexpr int kGeomGrads = 7;  // d xy (2), d conic (3), d opacity, d depth

template <int kC, class V>
constexpr bool pixel_major() {
  return kC >= 16 && kC % V::kWidth == 0;
}

// acc[c] += col[c]·w over one pixel's channels.
template <int kC, class V>
inline void add_weighted_channels(float* acc, const float* col, float w) {
  const typename V::F vw = V::set1(w);
  for (int c = 0; c < kC; c += V::kWidth) V::store(acc + c, V::add(V::load(acc + c), V::mul(V::load(col + c), vw)));
}

// α and e^−σ on one vector of pixels at offsets (dx, dy) = mean − pixel centre, given a2 = −½A, by = −B·dy
// and cy = −½C·dy² per lane: α is 0 where the splat is skipped (σ < 0 from rounding, or α < 1/255). Every
// layout of pixels in lanes goes through here, so that forward and backward, rows and pairs of rows, take
// the same decisions bit for bit.
template <class V>
inline void splat_alpha_lanes(typename V::F a2, typename V::F by, typename V::F cy, typename V::F vo,
                              typename V::F dx, float* alpha, float* gauss) {
  using F = typename V::F;
  const F power = V::add(V::add(V::mul(V::mul(a2, dx), dx), V::mul(by, dx)), cy);
  const F g = simd::exp_nonpositive<V>(power);
  const F a = V::min(V::set1(kMaxAlpha), V::mul(vo, g));
  const F keep = V::and_(V::cmple(power, V::zero()), V::cmpge(a, V::set1(kMinAlpha)));
  V::store(alpha, V::and_(keep, a));
  V::store(gauss, g);
}

// α and e^−σ of a splat along one pixel row of at most kTileSize pixels: pixel k is at offset
// (dx0 − k, dy). alpha and gauss must hold kTileSize floats (whole groups are written; kTileSize is a
// multiple of kWidth).
template <class V>
inline void splat_alpha_row(float A, float B, float C, float o, float dx0, float dy, int len, float* alpha,
                            float* gauss) {
  using F = typename V::F;
  const F a2 = V::set1(-0.5f * A), by = V::set1(-B * dy), cy = V::set1(-0.5f * C * dy * dy), vo = V::set1(o);
  const F vdx0 = V::set1(dx0), ramp = V::to_float(V::rampi());
  for (int k = 0; k < len; k += V::kWidth) {
    const F dx = V::sub(vdx0, V::add(V::set1(static_cast<float>(k)), ramp));
    splat_alpha_lanes<V>(a2, by, cy, vo, dx, alpha + k, gauss + k);
  }
}

// The same for the first kWidth/2 pixels of two rows: lanes [0, kWidth/2) on row dy_lo, the others on row
// dy_hi. Writes one vector to alpha and gauss.
template <class V>
inline void splat_alpha_pair(float A, float B, float C, float o, float dx0, float dy_lo, float dy_hi, float* alpha,
                             float* gauss) {
  using F = typename V::F;
  const F by = V::set1_halves(-B * dy_lo, -B * dy_hi);
  const F cy = V::set1_halves(-0.5f * C * dy_lo * dy_lo, -0.5f * C * dy_hi * dy_hi);
  const F dx = V::sub(V::set1(dx0), V::add(V::set1(0.f), V::to_float(V::ramp_halves())));
  splat_alpha_lanes<V>(V::set1(-0.5f * A), by, cy, V::set1(o), dx, alpha, gauss);
}

template <int kC, class V>
void forward_tile(int tile, const RasterInputs& in, const ColorSource& source, const RasterForwardOutputs& out,
                  float* acc) {
  using F = typename V::F;
  using I = typename V::I;
  const int C = kC > 0 ? kC : in.channels;
  constexpr bool kPixelMajor = pixel_major<kC, V>();
  const int x0 = (tile % in.tiles_x) * kTileSize, y0 = (tile / in.tiles_x) * kTileSize;
  const int x1 = std::min(x0 + kTileSize, in.width), y1 = std::min(y0 + kTileSize, in.height);
  alignas(32) float T[kTileStorage], acc_depth[kTileStorage];
  alignas(32) int32_t last[kTileStorage], done[kTileStorage];  // done: all ones once the pixel is saturated
  std::fill(T, T + kTileStorage, 1.f);
  std::fill(acc_depth, acc_depth + kTileStorage, 0.f);
  std::fill(last, last + kTileStorage, -1);
  std::fill(done, done + kTileStorage, 0);
  std::fill(acc, acc + kTileStorage * C, 0.f);  // acc[c·kTileStorage + p], or acc[p·C + c] if pixel-major
  int remaining = (x1 - x0) * (y1 - y0);

  const F one = V::set1(1.f), min_T = V::set1(kMinTransmittance);
  const I ramp = V::rampi();
  const int32_t begin = in.tile_offsets[tile], end = in.tile_offsets[tile + 1];
  for (int32_t k = begin; k < end && remaining > 0; ++k) {
    const int32_t g = in.tile_ids[k];
    const int32_t pos = k - begin;
    if (k + kPrefetchDistance < end) {
      prefetch_splat(in, in.tile_ids[k + kPrefetchDistance]);
      source.prefetch(in.tile_ids[k + kPrefetchDistance]);
    }
    const float gx = in.xy[2 * g], gy = in.xy[2 * g + 1];
    const PixelSpan span = splat_span(gx, gy, in.extent[2 * g], in.extent[2 * g + 1], x0, y0, x1, y1);
    if (span.empty()) continue;
    const float A = in.conic[3 * g], B = in.conic[3 * g + 1], Cc = in.conic[3 * g + 2];
    const float o = in.opacity[g];
    const F vz = V::set1(in.depth[g]);
    const I vpos = V::set1i(pos);
    const float* col = nullptr;  // evaluated when the splat is first blended
    alignas(32) float row_alpha[kTileSize], row_gauss[kTileSize];
    const int len = span.j1 - span.j0;
    // One group of lanes: pixels p.. (or, paired, p.. and p + kTileSize..) with α alpha on the lanes in use.
    auto blend_group = [&](auto paired, int p, F alpha_in, I in_use) {
      constexpr bool kPaired = decltype(paired)::value;
      using G = GroupAccess<V, kPaired>;
      // Lanes not in use, already saturated, or skipped by α are neutral: α = 0 changes nothing.
      const I dn = G::loadi(done + p);
      const F live = V::as_float(V::andnoti(dn, in_use));
      const F alpha = V::and_(alpha_in, live);
      const F t = G::load(T + p);
      const F next_T = V::mul(t, V::sub(one, alpha));
      const F hit = V::cmpneq(alpha, V::zero());
      const F stop = V::and_(hit, V::cmplt(next_T, min_T));
      const int stop_bits = V::movemask(stop);
      if (stop_bits) {
        G::storei(done + p, V::ori(dn, V::as_int(stop)));
        remaining -= __builtin_popcount(stop_bits);
      }
      const F blend = V::andnot(stop, hit);
      if (!V::movemask(blend)) return;
      if (!col) col = source.get(g, C);
      const F a = V::and_(alpha, blend);
      const F weight = V::mul(a, t);
      if constexpr (kPixelMajor) {
        alignas(64) float w[V::kWidth];
        V::store(w, weight);
        for (int bits = V::movemask(blend); bits; bits &= bits - 1) {
          const int l = __builtin_ctz(static_cast<unsigned>(bits));
          add_weighted_channels<kC, V>(acc + G::pixel(p, l) * kC, col, w[l]);
        }
      } else {
        for (int c = 0; c < C; ++c) {
          float* dst = acc + c * kTileStorage + p;
          G::store(dst, V::add(G::load(dst), V::mul(V::set1(col[c]), weight)));
        }
      }
      G::store(acc_depth + p, V::add(G::load(acc_depth + p), V::mul(vz, weight)));
      G::store(T + p, V::mul(t, V::sub(one, a)));  // T·(1 − 0) = T on the other lanes, bit for bit
      const I bl = V::as_int(blend);
      G::storei(last + p, V::ori(V::andi(bl, vpos), V::andnoti(bl, G::loadi(last + p))));
    };
    const int row0 = (span.i0 - y0) * kTileSize + (span.j0 - x0);
    if constexpr (row_pairs<V>()) {
      if (2 * len <= V::kWidth) {
        constexpr int kHalf = V::kWidth / 2;
        const I half_lane = V::ramp_halves(), vlen = V::set1i(len);
        const I low_half = V::cmplti(ramp, V::set1i(kHalf));
        const float dx0 = gx - (span.j0 + 0.5f);
        for (int i = span.i0; i < span.i1; i += 2) {
          const bool second = i + 1 < span.i1;
          splat_alpha_pair<V>(A, B, Cc, o, dx0, gy - (i + 0.5f), gy - ((i + 1) + 0.5f), row_alpha, row_gauss);
          I in_use = V::cmplti(half_lane, vlen);
          if (!second) in_use = V::andi(in_use, low_half);
          blend_group(std::true_type{}, row0 + (i - span.i0) * kTileSize, V::load(row_alpha), in_use);
        }
        continue;
      }
    }
    const I vlen = V::set1i(len);
    for (int i = span.i0; i < span.i1; ++i) {
      splat_alpha_row<V>(A, B, Cc, o, gx - (span.j0 + 0.5f), gy - (i + 0.5f), len, row_alpha, row_gauss);
      const int row = row0 + (i - span.i0) * kTileSize;
      for (int q = 0; q < len; q += V::kWidth)
        blend_group(std::false_type{}, row + q, V::load(row_alpha + q), V::cmplti(V::addi(V::set1i(q), ramp), vlen));
    }
  }

  const int64_t plane = static_cast<int64_t>(in.width) * in.height;
  for (int i = y0; i < y1; ++i)
    for (int j = x0; j < x1; ++j) {
      const int p = (i - y0) * kTileSize + (j - x0);
      const int64_t pix = static_cast<int64_t>(i) * in.width + j;
      for (int c = 0; c < C; ++c) {
        const float value = kPixelMajor ? acc[p * C + c] : acc[c * kTileStorage + p];
        out.image[c * plane + pix] = value + T[p] * in.background[c];
      }
      out.alpha[pix] = 1.f - T[p];
      out.depth[pix] = acc_depth[p];
      out.t_final[pix] = T[p];
      out.last[pix] = last[p];
    }
}

template <int kC, class V>
void forward(const RasterInputs& in, const ColorSource& source, const RasterForwardOutputs& out) {
  const int tiles = in.tiles_x * in.tiles_y;
#pragma omp parallel
  {
    std::vector<float> acc(static_cast<size_t>(kTileStorage) * in.channels);
#pragma omp for schedule(dynamic)
    for (int t = 0; t < tiles; ++t) forward_tile<kC, V>(t, in, source, out, acc.data());
  }
}

// Where one thread accumulates: per-Gaussian geometry gradients [N,7] and colour gradients [N,C]. A slot
// is written (not added) the first time the thread touches that Gaussian, so the buffers never need zeroing.
struct GradBuffer {
  float* geom;
  float* colors;
  uint8_t* touched;
};

// Per-pixel state of one tile, indexed p = row·kTileSize + column (as in the forward).
struct TileState {
  alignas(32) float T[kTileStorage];     // transmittance in front of the splat being processed
  alignas(32) float RG[kTileStorage];    // R·g: upstream-weighted colour of the splats behind it
  alignas(32) float RD[kTileStorage];    // the same for depth
  alignas(32) float bgT[kTileStorage];   // T_final·(bg·g)
  alignas(32) float gaT[kTileStorage];   // T_final·(d loss / d alpha)
  alignas(32) float gd[kTileStorage];    // d loss / d depth
  alignas(32) int32_t last[kTileStorage];
};

// dcol: scratch of (kWidth + 1)·C floats, aligned for V::F — per-lane colour-gradient accumulators, then
// their sums.
template <int kC, class V>
void backward_tile(int tile, const RasterInputs& in, const RasterBackwardInputs& bin, GradBuffer buf,
                   float* grad_pixels, float* dcol) {
  using F = typename V::F;
  using I = typename V::I;
  const int C = kC > 0 ? kC : in.channels;
  constexpr bool kPixelMajor = pixel_major<kC, V>();
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
  // [c·kTileStorage + p], or [p·C + c] if pixel-major
  std::fill(grad_pixels, grad_pixels + kTileStorage * C, 0.f);
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
        grad_pixels[kPixelMajor ? p * C + c : c * kTileStorage + p] = g;
        dot += g * in.background[c];
      }
      st.bgT[p] = tf * dot;
      st.gaT[p] = bin.d_alpha ? tf * bin.d_alpha[pix] : 0.f;
      st.gd[p] = bin.d_depth ? bin.d_depth[pix] : 0.f;
      st.last[p] = bin.last[pix];
      max_last = std::max(max_last, st.last[p]);
    }

  F* dcolv = reinterpret_cast<F*>(dcol);
  float* dcol_sum = dcol + V::kWidth * C;
  const F one = V::set1(1.f), half = V::set1(0.5f), max_alpha = V::set1(kMaxAlpha);
  const I ramp = V::rampi();
  const int32_t begin = in.tile_offsets[tile];
  for (int32_t k = begin + max_last; k >= begin; --k) {
    const int32_t g = in.tile_ids[k];
    const int32_t pos = k - begin;
    if (k - kPrefetchDistance >= begin) prefetch_splat(in, in.tile_ids[k - kPrefetchDistance]);
    const float gx = in.xy[2 * g], gy = in.xy[2 * g + 1];
    const PixelSpan span = splat_span(gx, gy, in.extent[2 * g], in.extent[2 * g + 1], x0, y0, x1, y1);
    if (span.empty()) continue;
    const float A = in.conic[3 * g], B = in.conic[3 * g + 1], Cc = in.conic[3 * g + 2];
    const float o = in.opacity[g];
    const float* col = in.colors + static_cast<int64_t>(g) * C;
    alignas(32) float row_alpha[kTileSize], row_gauss[kTileSize];
    const int len = span.j1 - span.j0;
    bool touched = false;
    F v_gx = V::zero(), v_gy = V::zero(), v_A = V::zero(), v_B = V::zero(), v_C = V::zero(), v_o = V::zero();
    F v_z = V::zero();
    const F vz = V::set1(in.depth[g]), vo = V::set1(o), vA = V::set1(A), vB = V::set1(B), vCc = V::set1(Cc);
    const I vpos = V::set1i(pos);
    // One group of lanes: pixels p.. (or, paired, p.. and p + kTileSize..), with α, e^−σ, the lanes in use
    // and each lane's offset (dx, dy) from the pixel centre to the mean.
    auto group = [&](auto paired, int p, F alpha_in, F gauss, I in_use, F dx, F vdy) {
      constexpr bool kPaired = decltype(paired)::value;
      using G = GroupAccess<V, kPaired>;
      // Live lanes: in use and not behind the pixel's last blended splat (pos <= last).
      const I live = V::andnoti(V::cmpgti(vpos, G::loadi(st.last + p)), in_use);
      const F alpha = V::and_(alpha_in, V::as_float(live));
      const F valid = V::cmpneq(alpha, V::zero());
      if (!V::movemask(valid)) return;
      if (!touched) {
        if constexpr (kPixelMajor)
          std::fill(dcol_sum, dcol_sum + C, 0.f);
        else
          for (int c = 0; c < C; ++c) dcolv[c] = V::zero();
        touched = true;
      }
      const F inv = V::div(one, V::sub(one, alpha));
      const F Ti = V::mul(G::load(st.T + p), inv);
      const F weight = V::mul(alpha, Ti);
      F cg = V::zero();
      if constexpr (kPixelMajor) {
        // Per valid pixel: cg = col · (d loss / d pixel) and the colour gradient += weight · (d loss / d pixel).
        alignas(64) float w[V::kWidth], cgl[V::kWidth] = {};
        V::store(w, weight);
        for (int bits = V::movemask(valid); bits; bits &= bits - 1) {
          const int l = __builtin_ctz(static_cast<unsigned>(bits));
          const float* gp = grad_pixels + G::pixel(p, l) * kC;
          F dot = V::zero();
          for (int c = 0; c < kC; c += V::kWidth) dot = V::add(dot, V::mul(V::load(col + c), V::load(gp + c)));
          cgl[l] = V::hsum(dot);
          add_weighted_channels<kC, V>(dcol_sum, gp, w[l]);
        }
        cg = V::load(cgl);
      } else {
        for (int c = 0; c < C; ++c) {
          const F gp = G::load(grad_pixels + c * kTileStorage + p);
          cg = V::add(cg, V::mul(V::set1(col[c]), gp));
          dcolv[c] = V::add(dcolv[c], V::mul(weight, gp));
        }
      }
      const F rg = G::load(st.RG + p), rd = G::load(st.RD + p), gd = G::load(st.gd + p);
      F d_alpha = V::sub(V::mul(Ti, cg), V::mul(V::add(rg, G::load(st.bgT + p)), inv));
      d_alpha = V::add(d_alpha, V::mul(G::load(st.gaT + p), inv));
      d_alpha = V::add(d_alpha, V::mul(gd, V::sub(V::mul(vz, Ti), V::mul(rd, inv))));
      v_z = V::add(v_z, V::mul(gd, weight));
      G::store(st.RG + p, V::add(rg, V::mul(cg, weight)));
      G::store(st.RD + p, V::add(rd, V::mul(vz, weight)));
      G::store(st.T + p, Ti);
      // α = o·e^power moves with o and the shape only where it is not clamped at 0.99.
      const F moving = V::and_(valid, V::cmple(V::mul(vo, gauss), max_alpha));
      const F da = V::and_(d_alpha, moving);
      v_o = V::add(v_o, V::mul(gauss, da));
      const F d_power = V::mul(da, alpha);
      v_gx = V::sub(v_gx, V::mul(d_power, V::add(V::mul(vA, dx), V::mul(vB, vdy))));
      v_gy = V::sub(v_gy, V::mul(d_power, V::add(V::mul(vCc, vdy), V::mul(vB, dx))));
      v_A = V::sub(v_A, V::mul(V::mul(d_power, half), V::mul(dx, dx)));
      v_B = V::sub(v_B, V::mul(d_power, V::mul(dx, vdy)));
      v_C = V::sub(v_C, V::mul(V::mul(d_power, half), V::mul(vdy, vdy)));
    };
    const int row0 = (span.i0 - y0) * kTileSize + (span.j0 - x0);
    const float dx0 = gx - (span.j0 + 0.5f);
    const F vdx0 = V::set1(dx0);
    const I vlen = V::set1i(len);
    bool paired_rows = false;
    if constexpr (row_pairs<V>()) {
      if (2 * len <= V::kWidth) {
        paired_rows = true;
        const I half_lane = V::ramp_halves(), low_half = V::cmplti(ramp, V::set1i(V::kWidth / 2));
        const I lanes_in_span = V::cmplti(half_lane, vlen);
        const F dx = V::sub(vdx0, V::to_float(half_lane));
        for (int i = span.i0; i < span.i1; i += 2) {
          const float dy_lo = gy - (i + 0.5f), dy_hi = gy - ((i + 1) + 0.5f);
          splat_alpha_pair<V>(A, B, Cc, o, dx0, dy_lo, dy_hi, row_alpha, row_gauss);
          const I in_use = i + 1 < span.i1 ? lanes_in_span : V::andi(lanes_in_span, low_half);
          group(std::true_type{}, row0 + (i - span.i0) * kTileSize, V::load(row_alpha), V::load(row_gauss), in_use,
                dx, V::set1_halves(dy_lo, dy_hi));
        }
      }
    }
    if (!paired_rows) {
      for (int i = span.i0; i < span.i1; ++i) {
        const float dy = gy - (i + 0.5f);
        splat_alpha_row<V>(A, B, Cc, o, dx0, dy, len, row_alpha, row_gauss);
        const int row = row0 + (i - span.i0) * kTileSize;
        for (int q = 0; q < len; q += V::kWidth) {
          const I lane = V::addi(V::set1i(q), ramp);
          group(std::false_type{}, row + q, V::load(row_alpha + q), V::load(row_gauss + q),
                V::cmplti(lane, vlen), V::sub(vdx0, V::to_float(lane)), V::set1(dy));
        }
      }
    }
    if (!touched) continue;
    const float sums[kGeomGrads] = {V::hsum(v_gx), V::hsum(v_gy), V::hsum(v_A), V::hsum(v_B),
                                    V::hsum(v_C),  V::hsum(v_o),  V::hsum(v_z)};
    if constexpr (!kPixelMajor)
      for (int c = 0; c < C; ++c) dcol_sum[c] = V::hsum(dcolv[c]);
    float* geom = buf.geom + static_cast<int64_t>(g) * kGeomGrads;
    float* gc = buf.colors + static_cast<int64_t>(g) * C;
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

// The buffers live with the calling thread and are reused by the next call: allocating tens of MB per
// iteration costs page faults comparable to the work itself.
struct ThreadGrads {
  std::vector<float> geom, colors;
  std::vector<uint8_t> touched;
};

template <int kC, class V>
void backward(int64_t n, const RasterInputs& in, const RasterBackwardInputs& bin, const RasterGrads& out) {
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
    // Scratch: the tile's upstream gradient (channel-major) and the colour accumulators, aligned for V::F.
    std::vector<float> grad_pixels(static_cast<size_t>(kTileStorage) * C), dcol_buf((V::kWidth + 1) * C + 8);
    float* dcol = dcol_buf.data();
    while (reinterpret_cast<uintptr_t>(dcol) % alignof(typename V::F)) ++dcol;
    // Tiles dealt round-robin, not dynamically: which thread's buffer a tile's gradients land in (and so
    // the rounding of the sums below) must not depend on timing, or two runs of one seed would differ
    // (and a run resumed from a checkpoint would not reach the uninterrupted run's result).
#pragma omp for schedule(static, 1)
    for (int tile = 0; tile < tiles; ++tile) backward_tile<kC, V>(tile, in, bin, buf, grad_pixels.data(), dcol);
  }
  // Dynamic: the touched Gaussians come in runs (Z order); each row is summed on its own, whatever the split.
#pragma omp parallel for schedule(dynamic, 512)
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

// Both directions with the channel counts that get their own compiled loops.
template <class V>
void forward_any(const RasterInputs& in, const ColorSource& source, const RasterForwardOutputs& out) {
  switch (in.channels) {
    case 1: forward<1, V>(in, source, out); break;
    case 3: forward<3, V>(in, source, out); break;
    case 4: forward<4, V>(in, source, out); break;
    case 16: forward<16, V>(in, source, out); break;
    case 32: forward<32, V>(in, source, out); break;
    default: forward<0, V>(in, source, out); break;
  }
}

template <class V>
void backward_any(int64_t n, const RasterInputs& in, const RasterBackwardInputs& bin, const RasterGrads& out) {
  switch (in.channels) {
    case 1: backward<1, V>(n, in, bin, out); break;
    case 3: backward<3, V>(n, in, bin, out); break;
    case 4: backward<4, V>(n, in, bin, out); break;
    case 16: backward<16, V>(n, in, bin, out); break;
    case 32: backward<32, V>(n, in, bin, out); break;
    default: backward<0, V>(n, in, bin, out); break;
  }
}

}  // namespace lrf::splat::tiles
