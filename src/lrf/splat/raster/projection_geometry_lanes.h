#pragma once
// The geometry of the projection on vector lanes, kWidth Gaussians at a time: camera-space mean, rotation
// and scales, the 3D covariance, the clamped Jacobian and the dilated screen covariance. The forward
// (projection_lanes.h) computes it from the parameters and the backward (projection_backward_lanes.h)
// computes it again instead of storing it; one function, so that both see the same bits.
#include <limits>

#include "lrf/splat/raster/projection.h"
#include "lrf/splat/raster/simd.h"

namespace lrf::splat::lanes {

template <class V>
struct LaneGeometry {
  using F = typename V::F;
  F p[3];                  // camera-space mean
  F qlen, qn[4];           // the quaternion's norm and the normalised quaternion (w, x, y, z)
  F Rq[9], s[3];           // rotation (row-major) and scales
  F M[9], Sigma[9];        // M = Rq·S, Σ = M·Mᵀ
  F rx, ry;                // x/z and y/z, clamped to 1.3× each side's extent of the image
  F inside_x, inside_y;    // masks: the ratio was not clamped (the clamp passes no gradient)
  F T[6], TS[6];           // T = J·W (2×3), and T·Σ
  F a0, b0, c0;            // Σ2 = T Σ Tᵀ before the low-pass dilation
  F a, b, c, det;          // dilated Σ2' = [[a, b], [b, c]] and its determinant
  F comp, comp_moves;      // Mip compensation √(det Σ2 / det Σ2') (1 without the filter); mask: above its floor
  F valid;                 // mask: in front of the near plane, a finite non-zero quaternion, det > 0
};

// in[0..2]: mean, in[3..5]: log-scales, in[6..9]: quaternion, one lane per Gaussian.
template <class V>
LaneGeometry<V> lane_geometry(const float (*in)[V::kWidth], const Viewpoint& view) {
  using F = typename V::F;
  LaneGeometry<V> g;
  const F zero = V::zero(), one = V::set1(1.f), two = V::set1(2.f);
  auto c = [](double v) { return V::set1(static_cast<float>(v)); };
  float W[9];
  for (int k = 0; k < 9; ++k) W[k] = static_cast<float>(view.R[k]);
  const float fx = static_cast<float>(view.fx), fy = static_cast<float>(view.fy);
  const float cx = static_cast<float>(view.cx), cy = static_cast<float>(view.cy);

  const F mx = V::load(in[0]), my = V::load(in[1]), mz = V::load(in[2]);
  for (int r = 0; r < 3; ++r)
    g.p[r] = V::add(V::add(V::add(V::mul(V::set1(W[3 * r]), mx), V::mul(V::set1(W[3 * r + 1]), my)),
                           V::mul(V::set1(W[3 * r + 2]), mz)),
                    c(view.t[r]));
  const F z = g.p[2];
  g.valid = V::cmpge(z, c(view.near));

  const F q0 = V::load(in[6]), q1 = V::load(in[7]), q2 = V::load(in[8]), q3 = V::load(in[9]);
  g.qlen = V::sqrt(V::add(V::add(V::add(V::mul(q0, q0), V::mul(q1, q1)), V::mul(q2, q2)), V::mul(q3, q3)));
  g.valid = V::and_(g.valid, V::and_(V::cmpgt(g.qlen, zero),
                                     V::cmple(g.qlen, V::set1(std::numeric_limits<float>::max()))));
  g.qn[0] = V::div(q0, g.qlen), g.qn[1] = V::div(q1, g.qlen), g.qn[2] = V::div(q2, g.qlen);
  g.qn[3] = V::div(q3, g.qlen);
  const F qw = g.qn[0], qx = g.qn[1], qy = g.qn[2], qz = g.qn[3];
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
  for (int k = 0; k < 9; ++k) g.Rq[k] = Rq[k];
  for (int k = 0; k < 3; ++k) {
    g.s[k] = simd::exp_any<V>(V::load(in[3 + k]));
    for (int r = 0; r < 3; ++r) g.M[3 * r + k] = V::mul(Rq[3 * r + k], g.s[k]);
  }
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k)
      g.Sigma[3 * r + k] = V::add(V::add(V::mul(g.M[3 * r], g.M[3 * k]), V::mul(g.M[3 * r + 1], g.M[3 * k + 1])),
                                  V::mul(g.M[3 * r + 2], g.M[3 * k + 2]));

  // Jacobian clamp: 3DGS clamps x/z to ±1.3·tan(fov/2). With an off-centre principal point the two sides
  // of the image differ, so each side gets 1.3× its own extent (identical to 3DGS when cx = W/2).
  const float width = static_cast<float>(view.width), height = static_cast<float>(view.height);
  auto clamp = [&](F num, float lim_neg, float lim_pos, F* r, F* inside) {
    const F ratio = V::div(num, z);
    *inside = V::and_(V::cmpge(ratio, V::set1(-lim_neg)), V::cmple(ratio, V::set1(lim_pos)));
    *r = V::min(V::max(ratio, V::set1(-lim_neg)), V::set1(lim_pos));
  };
  clamp(g.p[0], 1.3f * cx / fx, 1.3f * (width - cx) / fx, &g.rx, &g.inside_x);
  clamp(g.p[1], 1.3f * cy / fy, 1.3f * (height - cy) / fy, &g.ry, &g.inside_y);
  const F vfx = V::set1(fx), vfy = V::set1(fy);
  const F J00 = V::div(vfx, z), J02 = V::div(V::sub(zero, V::mul(vfx, g.rx)), z);
  const F J11 = V::div(vfy, z), J12 = V::div(V::sub(zero, V::mul(vfy, g.ry)), z);
  for (int k = 0; k < 3; ++k) {
    g.T[k] = V::add(V::mul(J00, V::set1(W[k])), V::mul(J02, V::set1(W[6 + k])));
    g.T[3 + k] = V::add(V::mul(J11, V::set1(W[3 + k])), V::mul(J12, V::set1(W[6 + k])));
  }
  for (int r = 0; r < 2; ++r)
    for (int k = 0; k < 3; ++k)
      g.TS[3 * r + k] = V::add(V::add(V::mul(g.T[3 * r], g.Sigma[k]), V::mul(g.T[3 * r + 1], g.Sigma[3 + k])),
                               V::mul(g.T[3 * r + 2], g.Sigma[6 + k]));
  const F* T = g.T;
  const F* TS = g.TS;
  g.a0 = V::add(V::add(V::mul(TS[0], T[0]), V::mul(TS[1], T[1])), V::mul(TS[2], T[2]));
  g.b0 = V::add(V::add(V::mul(TS[0], T[3]), V::mul(TS[1], T[4])), V::mul(TS[2], T[5]));
  g.c0 = V::add(V::add(V::mul(TS[3], T[3]), V::mul(TS[4], T[4])), V::mul(TS[5], T[5]));
  const F dilation = c(view.dilation);
  g.a = V::add(g.a0, dilation), g.b = g.b0, g.c = V::add(g.c0, dilation);
  g.det = V::sub(V::mul(g.a, g.c), V::mul(g.b, g.b));
  g.valid = V::and_(g.valid, V::cmpgt(g.det, zero));
  g.comp = one;
  g.comp_moves = zero;
  if (view.mip_2d_filter) {
    const F ratio = V::div(V::sub(V::mul(g.a0, g.c0), V::mul(g.b0, g.b0)), g.det);
    g.comp_moves = V::cmpgt(ratio, V::set1(kMinMipRatio));
    g.comp = V::sqrt(V::max(ratio, V::set1(kMinMipRatio)));
  }
  return g;
}

}  // namespace lrf::splat::lanes
