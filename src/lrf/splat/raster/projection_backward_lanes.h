#pragma once
// project_backward written against the vector interface of simd.h, kWidth Gaussians at a time, and
// instantiated per width next to the forward (projection_lanes.h). It recomputes the forward's geometry
// (projection_geometry_lanes.h: mean in camera space, rotation, Σ, the clamped Jacobian, the dilated Σ2)
// instead of storing it, then applies the chain rule back to the means, log-scales, quaternions and
// opacity logits. On a trained field nearly every visible Gaussian gets a gradient (fern's 7k latent
// field: 42.6k of 44k per view), so this runs on most rows; one Gaussian at a time it held 7 % of a latent
// training step.
//
// Lanes whose Gaussian got no gradient, was culled (radius 0) or is degenerate write zeros. The math is
// float, as in the forward; the exponentials are simd.h's, so every width gives the same bits.
#include <omp.h>

#include <algorithm>
#include <cstdint>

#include "lrf/splat/raster/projection.h"
#include "lrf/splat/raster/projection_geometry_lanes.h"
#include "lrf/splat/raster/simd.h"

namespace lrf::splat::lanes {

// One float per lane with arithmetic operators, so that the chain rule below reads like the formulas.
template <class V>
struct Num {
  typename V::F v;
  static Num all(float x) { return {V::set1(x)}; }
};
template <class V>
inline Num<V> operator+(Num<V> a, Num<V> b) {
  return {V::add(a.v, b.v)};
}
template <class V>
inline Num<V> operator-(Num<V> a, Num<V> b) {
  return {V::sub(a.v, b.v)};
}
template <class V>
inline Num<V> operator*(Num<V> a, Num<V> b) {
  return {V::mul(a.v, b.v)};
}
template <class V>
inline Num<V> operator/(Num<V> a, Num<V> b) {
  return {V::div(a.v, b.v)};
}
template <class V>
inline Num<V> operator-(Num<V> a) {
  return {V::sub(V::zero(), a.v)};
}
// The lanes of a where the mask is set, zero elsewhere.
template <class V>
inline Num<V> where(typename V::F mask, Num<V> a) {
  return {V::and_(mask, a.v)};
}

// Gaussians [first, first + count), count <= V::kWidth; lanes past count repeat the last Gaussian and are
// not written.
template <class V>
void project_backward_block(int64_t first, int count, const float* means, const float* log_scales,
                            const float* quats, const float* opacity_logits, const int32_t* radii,
                            const Viewpoint& view, const ProjectedGrads& gin, float* d_means,
                            float* d_log_scales, float* d_quats, float* d_opacity_logits) {
  using F = typename V::F;
  using N = Num<V>;
  constexpr int L = V::kWidth;
  for (int k = 0; k < count; ++k) {
    const int64_t i = first + k;
    std::fill(d_means + 3 * i, d_means + 3 * i + 3, 0.f);
    std::fill(d_log_scales + 3 * i, d_log_scales + 3 * i + 3, 0.f);
    std::fill(d_quats + 4 * i, d_quats + 4 * i + 4, 0.f);
    d_opacity_logits[i] = 0;
  }
  // Inputs and upstream gradients gathered into lanes (structure of arrays); `wanted` marks the lanes of
  // visible Gaussians with a non-zero upstream gradient.
  alignas(32) float in[11][L], up[7][L];
  alignas(32) int32_t wanted[L];
  bool any_lane = false;
  for (int k = 0; k < L; ++k) {
    const int64_t i = first + std::min(k, count - 1);
    const float g[7] = {gin.xy[2 * i], gin.xy[2 * i + 1], gin.conic[3 * i], gin.conic[3 * i + 1],
                        gin.conic[3 * i + 2], gin.opacity[i], gin.depth[i]};
    bool nonzero = false;
    for (int m = 0; m < 7; ++m) {
      up[m][k] = g[m];
      nonzero |= g[m] != 0;
    }
    const bool take = k < count && radii[i] != 0 && nonzero;
    wanted[k] = take ? -1 : 0;
    any_lane |= take;
    for (int c = 0; c < 3; ++c) in[c][k] = means[3 * i + c];
    for (int c = 0; c < 3; ++c) in[3 + c][k] = log_scales[3 * i + c];
    for (int c = 0; c < 4; ++c) in[6 + c][k] = quats[4 * i + c];
    in[10][k] = opacity_logits[i];
  }
  if (!any_lane) return;

  auto load = [](const float* p) { return N{V::load(p)}; };
  const N zero{V::zero()}, one = N::all(1.f), two = N::all(2.f), half = N::all(0.5f);
  N W[9];
  for (int k = 0; k < 9; ++k) W[k] = N::all(static_cast<float>(view.R[k]));
  const N fx = N::all(static_cast<float>(view.fx)), fy = N::all(static_cast<float>(view.fy));

  // The forward's geometry, in the operator form of the chain rule below.
  const LaneGeometry<V> geo = lane_geometry<V>(in, view);
  const F ok = geo.valid, comp_moves = geo.comp_moves;
  auto wrap = [](const F* from, N* to, int count) {
    for (int k = 0; k < count; ++k) to[k] = N{from[k]};
  };
  N p[3], qn[4], Rq[9], s[3], M[9], T[6], TS[6];
  wrap(geo.p, p, 3), wrap(geo.qn, qn, 4), wrap(geo.Rq, Rq, 9), wrap(geo.s, s, 3), wrap(geo.M, M, 9);
  wrap(geo.T, T, 6), wrap(geo.TS, TS, 6);
  const N z = p[2], qlen{geo.qlen}, rx{geo.rx}, ry{geo.ry};
  const N a0{geo.a0}, b0{geo.b0}, c0{geo.c0}, a{geo.a}, b{geo.b}, c{geo.c}, det{geo.det}, comp{geo.comp};
  const N qw = qn[0], qx = qn[1], qy = qn[2], qz = qn[3];
  // Derivatives of the clamped ratios x/z and y/z (none where clamped).
  const N drx_dx = where<V>(geo.inside_x, one / z), drx_dz = where<V>(geo.inside_x, -p[0] / (z * z));
  const N dry_dy = where<V>(geo.inside_y, one / z), dry_dz = where<V>(geo.inside_y, -p[1] / (z * z));

  // Opacity: o = sigmoid(logit)·comp.
  const N sig = one / (one + N{simd::exp_any<V>(V::sub(V::zero(), V::load(in[10])))});
  const N g_op = load(up[5]);
  const N d_logit = g_op * comp * sig * (one - sig);
  const N d_comp = g_op * sig;

  // Conic (A, B, C) = (c, −b, a)/det of the dilated Σ2' = [[a, b], [b, c]].
  const N gA = load(up[2]), gB = load(up[3]), gC = load(up[4]);
  const N det2 = det * det;
  N da = (-gA * c * c + gB * b * c - gC * b * b) / det2;
  N db = (two * gA * b * c - gB * (a * c + b * b) + two * gC * a * b) / det2;
  N dc = (-gA * b * b + gB * a * b - gC * a * a) / det2;
  if (view.mip_2d_filter) {
    // comp = √(det0 / det), det0 = a0·c0 − b0², det = (a0 + h)(c0 + h) − b0².
    const N det0 = a0 * c0 - b0 * b0;
    const N k = d_comp / (two * comp * det2);
    da = da + where<V>(comp_moves, k * (c0 * det - det0 * c));
    dc = dc + where<V>(comp_moves, k * (a0 * det - det0 * a));
    db = db + where<V>(comp_moves, k * two * b0 * (det0 - det));
  }
  // Σ2 = T Σ Tᵀ with symmetric gradient G2 = [[da, db/2], [db/2, dc]].
  const N G2[4] = {da, half * db, half * db, dc};
  N dSigma[9];
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k)
      dSigma[3 * r + k] = T[r] * (G2[0] * T[k] + G2[1] * T[3 + k]) + T[3 + r] * (G2[2] * T[k] + G2[3] * T[3 + k]);
  // dL/dT = 2·G2·T·Σ; T = J·W, so dJ = dT·Wᵀ, of which only J00, J02, J11, J12 are non-zero.
  N dT[6];
  for (int r = 0; r < 2; ++r)
    for (int k = 0; k < 3; ++k) dT[3 * r + k] = two * (G2[2 * r] * TS[k] + G2[2 * r + 1] * TS[3 + k]);
  auto dJ = [&](int r, int k) { return dT[3 * r] * W[3 * k] + dT[3 * r + 1] * W[3 * k + 1] + dT[3 * r + 2] * W[3 * k + 2]; };
  const N dJ00 = dJ(0, 0), dJ02 = dJ(0, 2), dJ11 = dJ(1, 1), dJ12 = dJ(1, 2);
  const N zz = z * z;
  // J00 = fx/z, J02 = −fx·rx/z (rx the clamped x/z), likewise for y; then the projected mean and depth.
  const N gu = load(up[0]), gv = load(up[1]);
  N dp0 = dJ02 * (-fx / z) * drx_dx;
  N dp1 = dJ12 * (-fy / z) * dry_dy;
  N dp2 = -dJ00 * fx / zz - dJ11 * fy / zz;
  dp2 = dp2 + dJ02 * (fx * rx / zz - fx / z * drx_dz);
  dp2 = dp2 + dJ12 * (fy * ry / zz - fy / z * dry_dz);
  dp0 = dp0 + gu * fx / z;
  dp1 = dp1 + gv * fy / z;
  dp2 = dp2 - gu * fx * p[0] / zz - gv * fy * p[1] / zz + load(up[6]);
  N dm[3];
  for (int k = 0; k < 3; ++k) dm[k] = W[k] * dp0 + W[3 + k] * dp1 + W[6 + k] * dp2;

  // Σ = M Mᵀ → dM = 2·dΣ·M (dΣ symmetric); M = Rq·S.
  N dRq[9], dls[3];
  for (int k = 0; k < 3; ++k) {
    N ds = zero;
    for (int r = 0; r < 3; ++r) {
      const N dM = two * (dSigma[3 * r] * M[k] + dSigma[3 * r + 1] * M[3 + k] + dSigma[3 * r + 2] * M[6 + k]);
      dRq[3 * r + k] = dM * s[k];
      ds = ds + dM * Rq[3 * r + k];
    }
    dls[k] = ds * s[k];
  }
  const N* G = dRq;
  const N four = N::all(4.f);
  const N dqn[4] = {
      two * qz * (G[3] - G[1]) + two * qy * (G[2] - G[6]) + two * qx * (G[7] - G[5]),
      two * qy * (G[1] + G[3]) + two * qz * (G[2] + G[6]) + two * qw * (G[7] - G[5]) - four * qx * (G[4] + G[8]),
      two * qx * (G[1] + G[3]) + two * qw * (G[2] - G[6]) + two * qz * (G[5] + G[7]) - four * qy * (G[0] + G[8]),
      two * qw * (G[3] - G[1]) + two * qx * (G[2] + G[6]) + two * qy * (G[5] + G[7]) - four * qz * (G[0] + G[4]),
  };
  const N dot = qw * dqn[0] + qx * dqn[1] + qy * dqn[2] + qz * dqn[3];

  const F take = V::and_(ok, V::as_float(V::loadi(wanted)));
  alignas(32) float res[11][L];
  for (int k = 0; k < 3; ++k) V::store(res[k], where<V>(take, dm[k]).v);
  for (int k = 0; k < 3; ++k) V::store(res[3 + k], where<V>(take, dls[k]).v);
  for (int k = 0; k < 4; ++k) V::store(res[6 + k], where<V>(take, (dqn[k] - qn[k] * dot) / qlen).v);
  V::store(res[10], where<V>(take, d_logit).v);
  for (int k = 0; k < count; ++k) {
    if (!wanted[k]) continue;
    const int64_t i = first + k;
    for (int m = 0; m < 3; ++m) d_means[3 * i + m] = res[m][k];
    for (int m = 0; m < 3; ++m) d_log_scales[3 * i + m] = res[3 + m][k];
    for (int m = 0; m < 4; ++m) d_quats[4 * i + m] = res[6 + m][k];
    d_opacity_logits[i] = res[10][k];
  }
}

template <class V>
void project_backward(int64_t n, const float* means, const float* log_scales, const float* quats,
                      const float* opacity_logits, const int32_t* radii, const Viewpoint& view,
                      const ProjectedGrads& gin, float* d_means, float* d_log_scales, float* d_quats,
                      float* d_opacity_logits) {
  const int64_t blocks = (n + V::kWidth - 1) / V::kWidth;
  // Dynamic: blocks without a gradient cost little, and a Z-ordered field keeps them in runs (each block is
  // independent, so the split changes no result).
#pragma omp parallel for schedule(dynamic, 64)
  for (int64_t b = 0; b < blocks; ++b) {
    const int64_t first = b * V::kWidth;
    const int count = static_cast<int>(std::min<int64_t>(V::kWidth, n - first));
    project_backward_block<V>(first, count, means, log_scales, quats, opacity_logits, radii, view, gin, d_means,
                              d_log_scales, d_quats, d_opacity_logits);
  }
}

}  // namespace lrf::splat::lanes
