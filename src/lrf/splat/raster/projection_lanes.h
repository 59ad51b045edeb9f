#pragma once
// project_forward written against the vector interface of simd.h, kWidth Gaussians at a time, and
// instantiated per width next to the compositing kernels (raster_width_*.cpp). The backward
// (projection_backward_lanes.h) recomputes the same geometry; both use the exponential and logarithm of
// simd.h, so that every width gives the same bits.
#include <omp.h>

#include <algorithm>
#include <cstdint>
#include <limits>

#include "lrf/splat/raster/projection.h"
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
  auto c = [](double v) { return V::set1(static_cast<float>(v)); };
  float W[9];
  for (int k = 0; k < 9; ++k) W[k] = static_cast<float>(view.R[k]);
  const float fx = static_cast<float>(view.fx), fy = static_cast<float>(view.fy);
  const float cx = static_cast<float>(view.cx), cy = static_cast<float>(view.cy);

  // Camera-space mean.
  const F mx = V::load(in[0]), my = V::load(in[1]), mz = V::load(in[2]);
  F p[3];
  for (int r = 0; r < 3; ++r)
    p[r] = V::add(V::add(V::add(V::mul(V::set1(W[3 * r]), mx), V::mul(V::set1(W[3 * r + 1]), my)),
                         V::mul(V::set1(W[3 * r + 2]), mz)),
                  c(view.t[r]));
  const F z = p[2];
  F valid = V::cmpge(z, c(view.near));

  // Rotation from the normalised quaternion (w, x, y, z).
  const F q0 = V::load(in[6]), q1 = V::load(in[7]), q2 = V::load(in[8]), q3 = V::load(in[9]);
  const F qlen = V::sqrt(V::add(V::add(V::add(V::mul(q0, q0), V::mul(q1, q1)), V::mul(q2, q2)), V::mul(q3, q3)));
  valid = V::and_(valid, V::and_(V::cmpgt(qlen, zero), V::cmple(qlen, V::set1(std::numeric_limits<float>::max()))));
  const F qw = V::div(q0, qlen), qx = V::div(q1, qlen), qy = V::div(q2, qlen), qz = V::div(q3, qlen);
  const F Rq[9] = {
      V::sub(one, V::mul(two, V::add(V::mul(qy, qy), V::mul(qz, qz)))),
      V::mul(two, V::sub(V::mul(qx, qy), V::mul(qw, qz))),
      V::mul(two, V::add(V::mul(qx, qz), V::mul(qw, qy))),
      V::mul(two, V::add(V::mul(qx, qy), V::mul(qw, qz))),
      V::sub(one, V::mul(two, V::add(V::mul(qx, qx), V::mul(qz, qz)))),
      V::mul(two, V::sub(V::mul(qy, qz), V::mul(qw, qx))),
      V::mul(two, V::sub(V::mul(qx, qz), V::mul(qw, qy))),
      V::mul(two, V::add(V::mul(qy, qz), V::mul(qw, qx))),
      V::sub(one, V::mul(two, V::add(V::mul(qx, qx), V::mul(qy, qy)))),
  };
  // Σ = M·Mᵀ with M = Rq·S (symmetric: six entries).
  F M[9];
  for (int k = 0; k < 3; ++k) {
    const F s = simd::exp_any<V>(V::load(in[3 + k]));
    for (int r = 0; r < 3; ++r) M[3 * r + k] = V::mul(Rq[3 * r + k], s);
  }
  auto sigma = [&](int r, int k) {
    return V::add(V::add(V::mul(M[3 * r], M[3 * k]), V::mul(M[3 * r + 1], M[3 * k + 1])),
                  V::mul(M[3 * r + 2], M[3 * k + 2]));
  };
  const F s00 = sigma(0, 0), s01 = sigma(0, 1), s02 = sigma(0, 2), s11 = sigma(1, 1), s12 = sigma(1, 2),
          s22 = sigma(2, 2);
  const F Sigma[9] = {s00, s01, s02, s01, s11, s12, s02, s12, s22};

  // Jacobian with x/z and y/z clamped to 1.3× each side's extent of the image. The limits in float, computed
  // as the backward computes them, so that both clamp the same lanes.
  const float width = static_cast<float>(view.width), height = static_cast<float>(view.height);
  const F rx = V::min(V::max(V::div(p[0], z), V::set1(-(1.3f * cx / fx))), V::set1(1.3f * (width - cx) / fx));
  const F ry = V::min(V::max(V::div(p[1], z), V::set1(-(1.3f * cy / fy))), V::set1(1.3f * (height - cy) / fy));
  const F vfx = V::set1(fx), vfy = V::set1(fy);
  const F J00 = V::div(vfx, z), J02 = V::div(V::sub(zero, V::mul(vfx, rx)), z);
  const F J11 = V::div(vfy, z), J12 = V::div(V::sub(zero, V::mul(vfy, ry)), z);
  F T[6];
  for (int k = 0; k < 3; ++k) {
    T[k] = V::add(V::mul(J00, V::set1(W[k])), V::mul(J02, V::set1(W[6 + k])));
    T[3 + k] = V::add(V::mul(J11, V::set1(W[3 + k])), V::mul(J12, V::set1(W[6 + k])));
  }
  F TS[6];
  for (int r = 0; r < 2; ++r)
    for (int k = 0; k < 3; ++k)
      TS[3 * r + k] = V::add(V::add(V::mul(T[3 * r], Sigma[k]), V::mul(T[3 * r + 1], Sigma[3 + k])),
                             V::mul(T[3 * r + 2], Sigma[6 + k]));
  const F a0 = V::add(V::add(V::mul(TS[0], T[0]), V::mul(TS[1], T[1])), V::mul(TS[2], T[2]));
  const F b0 = V::add(V::add(V::mul(TS[0], T[3]), V::mul(TS[1], T[4])), V::mul(TS[2], T[5]));
  const F c0 = V::add(V::add(V::mul(TS[3], T[3]), V::mul(TS[4], T[4])), V::mul(TS[5], T[5]));
  const F dilation = c(view.dilation);
  const F a = V::add(a0, dilation), b = b0, cc = V::add(c0, dilation);
  const F det = V::sub(V::mul(a, cc), V::mul(b, b));
  valid = V::and_(valid, V::cmpgt(det, zero));
  F comp = one;
  if (view.mip_2d_filter)
    comp = V::sqrt(V::max(V::div(V::sub(V::mul(a0, c0), V::mul(b0, b0)), det), V::set1(kMinMipRatio)));

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

  // The tiles it is binned to: Inria's rectangle, cut down to the tiles the α box reaches. The rasterizer
  // never draws outside the α box, so the cut only drops list entries that would draw nothing: the image
  // is the same bit for bit, with less binning and fewer entries to skip. Each side of the box is widened
  // by a pixel and a relative margin, for the rasterizer's different float rounding of its span.
  const F rel = V::set1(1e-6f);
  auto abs = [&](F v) { return V::max(v, V::sub(zero, v)); };
  const F reach_x = V::add(V::add(one, ex), V::mul(rel, V::add(abs(px), ex)));
  const F reach_y = V::add(V::add(one, ey), V::mul(rel, V::add(abs(py), ey)));
  const I x0 = tile_index(V::max(lo_x, V::sub(px, reach_x)), view.tiles_x());
  const I y0 = tile_index(V::max(lo_y, V::sub(py, reach_y)), view.tiles_y());
  const I x1 = tile_index(V::min(hi_x, V::add(V::add(px, reach_x), tile)), view.tiles_x());
  const I y1 = tile_index(V::min(hi_y, V::add(V::add(py, reach_y), tile)), view.tiles_y());
  const F binned = V::and_(shows, V::as_float(V::andi(V::cmpgti(x1, x0), V::cmpgti(y1, y0))));

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
