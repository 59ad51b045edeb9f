#pragma once
// project_forward written against the vector interface of simd.h, kWidth Gaussians at a time, and
// instantiated per width next to the compositing kernels (raster_width_*.cpp). The geometry
// (projection_geometry_lanes.h) is shared with the backward; everything uses the exponential and logarithm
// of simd.h, so that every width gives the same bits.
#include <omp.h>

#include <algorithm>
#include <cstdint>

#include "lrf/splat/raster/projection.h"
#include "lrf/splat/raster/projection_geometry_lanes.h"
#include "lrf/splat/raster/raster_kernels.h"
#include "lrf/splat/raster/simd.h"

namespace lrf::splat::lanes {

// Gaussians [first, first + count) with count <= V::kWidth; lanes past count repeat the last Gaussian and
// are not written.
template <class V>
void project_block(int64_t first, int count, const float* means, const float* log_scales, const float* quats,
                   const float* opacity_logits, const Viewpoint& view, const Projected& out) {
  using F = typename V::F;
  using I = typename V::I;
  constexpr int L = V::kWidth;
  // Inputs gathered into lanes (structure of arrays).
  alignas(32) float in[11][L];
  for (int k = 0; k < L; ++k) {
    const int64_t i = first + std::min(k, count - 1);
    for (int c = 0; c < 3; ++c) in[c][k] = means[3 * i + c];
    for (int c = 0; c < 3; ++c) in[3 + c][k] = log_scales[3 * i + c];
    for (int c = 0; c < 4; ++c) in[6 + c][k] = quats[4 * i + c];
    in[10][k] = opacity_logits[i];
  }
  const F zero = V::zero(), one = V::set1(1.f), two = V::set1(2.f);
  const LaneGeometry<V> g = lane_geometry<V>(in, view);
  F valid = g.valid;
  const F z = g.p[2], a = g.a, b = g.b, cc = g.c, det = g.det, comp = g.comp;
  const F* p = g.p;
  const float fx = static_cast<float>(view.fx), fy = static_cast<float>(view.fy);
  const float cx = static_cast<float>(view.cx), cy = static_cast<float>(view.cy);
  const F vfx = V::set1(fx), vfy = V::set1(fy);

  // Screen position, radius (Inria's ⌈3·√λmax⌉) and the tile rectangle in Inria's pixel coordinates.
  const F u = V::add(V::div(V::mul(vfx, p[0]), z), V::set1(cx));
  const F w = V::add(V::div(V::mul(vfy, p[1]), z), V::set1(cy));
  const F mid = V::mul(V::set1(0.5f), V::add(a, cc));
  const F lambda = V::add(mid, V::sqrt(V::max(V::sub(V::mul(mid, mid), det), V::set1(kMinDiscriminant))));
  const F bound = V::set1(kFarBound);
  valid = V::and_(valid, V::and_(V::and_(V::cmplt(u, bound), V::cmpgt(u, V::sub(zero, bound))),
                                 V::and_(V::cmplt(w, bound), V::cmpgt(w, V::sub(zero, bound)))));
  valid = V::and_(valid, V::cmplt(lambda, V::set1(kFarBound * kFarBound)));
  const F r3 = V::mul(V::set1(3.f), V::sqrt(lambda));
  I radius = V::truncate(r3);
  radius = V::subi(radius, V::as_int(V::cmplt(V::to_float(radius), r3)));  // ceil: + 1 where truncation fell short
  const F rf = V::to_float(radius);
  const F px = V::sub(u, V::set1(0.5f)), py = V::sub(w, V::set1(0.5f));
  const F tile = V::set1(static_cast<float>(kTileSize));
  // Clamped in float, then truncated: the same integers as truncating first and clamping the ints. The
  // truncation is monotone, so the larger (smaller) of two bounds gives the larger (smaller) index.
  auto tile_index = [&](F v, int tiles) {
    return V::truncate(V::min(V::set1(static_cast<float>(tiles)), V::max(zero, V::div(v, tile))));
  };
  // Inria's rectangle: [p − r, (p + r + kTileSize − 1)] / kTileSize, the end evaluated left to right as
  // its float expression is. A Gaussian whose rectangle is empty is not visible (radius 0).
  const F lo_x = V::sub(px, rf), lo_y = V::sub(py, rf);
  const F hi_x = V::sub(V::add(V::add(px, rf), tile), one), hi_y = V::sub(V::add(V::add(py, rf), tile), one);
  const I wide = V::cmpgti(tile_index(hi_x, view.tiles_x()), tile_index(lo_x, view.tiles_x()));
  const I tall = V::cmpgti(tile_index(hi_y, view.tiles_y()), tile_index(lo_y, view.tiles_y()));
  valid = V::and_(valid, V::as_float(V::andi(wide, tall)));

  // Opacity, and the α box: α = o·e^−σ >= 1/255 needs σ <= ln(255·o); the ellipse ½dᵀΣ'⁻¹d <= s spans
  // ±√(2s·Σ'xx) in x. The box only saves work: it is widened so that float rounding in the rasterizer can
  // never fall outside it.
  const F o = V::mul(V::div(one, V::add(one, simd::exp_any<V>(V::sub(zero, V::load(in[10]))))), comp);
  const F ratio = V::div(o, V::set1(kMinAlpha));
  const F s_max = simd::log_positive<V>(V::max(ratio, one));
  const F shows = V::and_(valid, V::cmpgt(s_max, zero));
  const F widen = V::set1(1.0001f), pad = V::set1(1e-3f);
  const F ex = V::add(V::mul(V::sqrt(V::mul(V::mul(two, s_max), a)), widen), pad);
  const F ey = V::add(V::mul(V::sqrt(V::mul(V::mul(two, s_max), cc)), widen), pad);

  // The tiles it is binned to: Inria's rectangle, cut down to the tiles holding a pixel centre of the α
  // box. The rasterizer draws only those pixels (the centres j + ½ within ex of the mean: j from
  // ⌈px − ex⌉ to ⌊px + ex⌋), so the cut only drops list entries that would draw nothing: the image is the
  // same bit for bit, with less binning and fewer entries to skip (fern's 7k RGB field: with the box
  // widened by a pixel instead, 21 % of its tile entries drew nothing). The pixel range is widened by a
  // margin (1e-3 px and 1e-6 of the coordinates, ~8 float steps) for the rasterizer's different rounding.
  const F rel = V::set1(1e-6f), margin = V::set1(1e-3f);
  auto abs = [&](F v) { return V::max(v, V::sub(zero, v)); };
  const F reach_x = V::add(V::add(margin, ex), V::mul(rel, V::add(abs(px), ex)));
  const F reach_y = V::add(V::add(margin, ey), V::mul(rel, V::add(abs(py), ey)));
  // The first and last pixel index of the range, within the image: ⌈v⌉ and ⌊v⌋ by truncation, of v clamped
  // to a pixel outside each side first (so that the ints stay small). first > last: no pixel to draw.
  auto near_image = [&](F v, int size) {
    return V::min(V::set1(static_cast<float>(size + 1)), V::max(V::set1(-1.f), v));
  };
  auto first_pixel = [&](F v, int size) {
    const F c = near_image(v, size);
    const I t = V::truncate(c);
    return V::max(zero, V::to_float(V::subi(t, V::as_int(V::cmplt(V::to_float(t), c)))));
  };
  auto last_pixel = [&](F v, int size) {
    const F c = near_image(v, size);
    const I t = V::truncate(c);
    const F last = V::to_float(V::addi(t, V::as_int(V::cmpgt(V::to_float(t), c))));
    return V::min(V::set1(static_cast<float>(size - 1)), last);
  };
  const F first_x = first_pixel(V::sub(px, reach_x), view.width);
  const F last_x = last_pixel(V::add(px, reach_x), view.width);
  const F first_y = first_pixel(V::sub(py, reach_y), view.height);
  const F last_y = last_pixel(V::add(py, reach_y), view.height);
  const I x0 = tile_index(V::max(lo_x, first_x), view.tiles_x());
  const I y0 = tile_index(V::max(lo_y, first_y), view.tiles_y());
  const I x1 = tile_index(V::min(hi_x, V::add(last_x, tile)), view.tiles_x());
  const I y1 = tile_index(V::min(hi_y, V::add(last_y, tile)), view.tiles_y());
  const F some_centre = V::and_(V::cmple(first_x, last_x), V::cmple(first_y, last_y));
  const F some_tile = V::as_float(V::andi(V::cmpgti(x1, x0), V::cmpgti(y1, y0)));
  const F binned = V::and_(V::and_(shows, some_centre), some_tile);

  alignas(32) float res[10][L];
  alignas(32) int32_t ires[5][L];
  V::store(res[0], V::and_(valid, u));
  V::store(res[1], V::and_(valid, w));
  V::store(res[2], V::and_(valid, z));
  V::store(res[3], V::and_(valid, V::div(cc, det)));
  V::store(res[4], V::and_(valid, V::div(V::sub(zero, b), det)));
  V::store(res[5], V::and_(valid, V::div(a, det)));
  V::store(res[6], V::and_(valid, o));
  V::store(res[7], V::and_(shows, ex));
  V::store(res[8], V::and_(shows, ey));
  const I valid_i = V::as_int(valid), binned_i = V::as_int(binned);
  V::storei(ires[0], V::andi(valid_i, radius));
  V::storei(ires[1], V::andi(binned_i, x0));
  V::storei(ires[2], V::andi(binned_i, y0));
  V::storei(ires[3], V::andi(binned_i, x1));
  V::storei(ires[4], V::andi(binned_i, y1));
  for (int k = 0; k < count; ++k) {
    const int64_t i = first + k;
    out.xy[2 * i] = res[0][k];
    out.xy[2 * i + 1] = res[1][k];
    out.depth[i] = res[2][k];
    for (int m = 0; m < 3; ++m) out.conic[3 * i + m] = res[3 + m][k];
    out.opacity[i] = res[6][k];
    out.extent[2 * i] = res[7][k];
    out.extent[2 * i + 1] = res[8][k];
    out.radii[i] = ires[0][k];
    for (int m = 0; m < 4; ++m) out.rect[4 * i + m] = ires[1 + m][k];
  }
}

template <class V>
void project_forward(int64_t n, const float* means, const float* log_scales, const float* quats,
                     const float* opacity_logits, const Viewpoint& view, const Projected& out) {
  const int64_t blocks = (n + V::kWidth - 1) / V::kWidth;
#pragma omp parallel for schedule(static)
  for (int64_t b = 0; b < blocks; ++b) {
    const int64_t first = b * V::kWidth;
    const int count = static_cast<int>(std::min<int64_t>(V::kWidth, n - first));
    project_block<V>(first, count, means, log_scales, quats, opacity_logits, view, out);
  }
}

}  // namespace lrf::splat::lanes
