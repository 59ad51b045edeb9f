#include "lrf/splat/raster/projection.h"

#include <omp.h>

#include <algorithm>
#include <cmath>

namespace lrf::splat {
namespace {

// Per-Gaussian math runs in float: it is ample for a 2×2 conic (the dilation keeps det Σ2' >= 0.09) and
// about twice as fast as double; the forward (projection_lanes.h) runs in float too.
using real = float;

// The view's numbers in that precision.
struct ViewF {
  explicit ViewF(const Viewpoint& v)
      : fx(real(v.fx)), fy(real(v.fy)), cx(real(v.cx)), cy(real(v.cy)), near(real(v.near)),
        dilation(real(v.dilation)), width(real(v.width)), height(real(v.height)), mip_2d_filter(v.mip_2d_filter) {
    for (int k = 0; k < 9; ++k) R[k] = real(v.R[k]);
    for (int k = 0; k < 3; ++k) t[k] = real(v.t[k]);
  }
  real R[9], t[3];
  real fx, fy, cx, cy, near, dilation, width, height;
  bool mip_2d_filter;
};


// The per-Gaussian quantities of the forward (projection_lanes.h computes them on vector lanes) that the
// backward needs again: it recomputes them, one Gaussian at a time, instead of storing them.
struct Geometry {
  real p[3];                  // camera-space mean
  real qn[4], qlen;           // normalised quaternion (w, x, y, z) and the input's norm
  real Rq[9];                 // rotation of the Gaussian, row-major
  real s[3];                  // scales
  real M[9];                  // Rq·S, Σ = M·Mᵀ
  real Sigma[9];              // 3D covariance
  real rx, ry;                // x/z and y/z, clamped to 1.3× the field of view for the Jacobian
  real drx_dx, drx_dz;        // their derivatives (0 where clamped)
  real dry_dy, dry_dz;
  real T[6];                  // J·W (2×3, row-major)
  real a0, b0, c0;            // Σ2 = T Σ Tᵀ before the low-pass
  real a, b, c, det;          // dilated Σ2' and its determinant
  real comp;                  // opacity compensation of the Mip 2D filter (1 without it)
  bool comp_floored;            // compensation sits on its floor: no gradient through it
};

inline void clamp_ratio(real num, real z, real lim_neg, real lim_pos, real* r, real* dr_dnum,
                        real* dr_dz) {
  const real ratio = num / z;
  if (ratio < -lim_neg || ratio > lim_pos) {
    *r = ratio < -lim_neg ? -lim_neg : lim_pos;
    *dr_dnum = 0;
    *dr_dz = 0;
  } else {
    *r = ratio;
    *dr_dnum = 1.0f / z;
    *dr_dz = -num / (z * z);
  }
}

// Returns false when the Gaussian is culled (behind the near plane or degenerate).
bool compute_geometry(const float* mu, const float* ls, const float* q, const ViewF& v, Geometry& g) {
  const real* W = v.R;
  for (int r = 0; r < 3; ++r) g.p[r] = W[3 * r] * mu[0] + W[3 * r + 1] * mu[1] + W[3 * r + 2] * mu[2] + v.t[r];
  const real z = g.p[2];
  if (!(z >= v.near)) return false;

  g.qlen = std::sqrt(real(q[0]) * q[0] + real(q[1]) * q[1] + real(q[2]) * q[2] + real(q[3]) * q[3]);
  if (!(g.qlen > 0) || !std::isfinite(g.qlen)) return false;
  for (int k = 0; k < 4; ++k) g.qn[k] = q[k] / g.qlen;
  const real qw = g.qn[0], qx = g.qn[1], qy = g.qn[2], qz = g.qn[3];
  real* Rq = g.Rq;
  Rq[0] = 1 - 2 * (qy * qy + qz * qz), Rq[1] = 2 * (qx * qy - qw * qz), Rq[2] = 2 * (qx * qz + qw * qy);
  Rq[3] = 2 * (qx * qy + qw * qz), Rq[4] = 1 - 2 * (qx * qx + qz * qz), Rq[5] = 2 * (qy * qz - qw * qx);
  Rq[6] = 2 * (qx * qz - qw * qy), Rq[7] = 2 * (qy * qz + qw * qx), Rq[8] = 1 - 2 * (qx * qx + qy * qy);
  for (int k = 0; k < 3; ++k) g.s[k] = std::exp(real(ls[k]));
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) g.M[3 * r + k] = Rq[3 * r + k] * g.s[k];
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k)
      g.Sigma[3 * r + k] = g.M[3 * r] * g.M[3 * k] + g.M[3 * r + 1] * g.M[3 * k + 1] + g.M[3 * r + 2] * g.M[3 * k + 2];

  // Jacobian clamp: 3DGS clamps x/z to ±1.3·tan(fov/2). With an off-centre principal point the two sides
  // of the image differ, so each side gets 1.3× its own extent (identical to 3DGS when cx = W/2).
  clamp_ratio(g.p[0], z, 1.3f * v.cx / v.fx, 1.3f * (v.width - v.cx) / v.fx, &g.rx, &g.drx_dx, &g.drx_dz);
  clamp_ratio(g.p[1], z, 1.3f * v.cy / v.fy, 1.3f * (v.height - v.cy) / v.fy, &g.ry, &g.dry_dy, &g.dry_dz);
  const real J[6] = {v.fx / z, 0, -v.fx * g.rx / z, 0, v.fy / z, -v.fy * g.ry / z};
  for (int r = 0; r < 2; ++r)
    for (int k = 0; k < 3; ++k) g.T[3 * r + k] = J[3 * r] * W[k] + J[3 * r + 1] * W[3 + k] + J[3 * r + 2] * W[6 + k];
  real TS[6];  // T·Σ
  for (int r = 0; r < 2; ++r)
    for (int k = 0; k < 3; ++k)
      TS[3 * r + k] = g.T[3 * r] * g.Sigma[k] + g.T[3 * r + 1] * g.Sigma[3 + k] + g.T[3 * r + 2] * g.Sigma[6 + k];
  g.a0 = TS[0] * g.T[0] + TS[1] * g.T[1] + TS[2] * g.T[2];
  g.b0 = TS[0] * g.T[3] + TS[1] * g.T[4] + TS[2] * g.T[5];
  g.c0 = TS[3] * g.T[3] + TS[4] * g.T[4] + TS[5] * g.T[5];
  g.a = g.a0 + v.dilation;
  g.b = g.b0;
  g.c = g.c0 + v.dilation;
  g.det = g.a * g.c - g.b * g.b;
  if (!(g.det > 0)) return false;
  g.comp = 1;
  g.comp_floored = false;
  if (v.mip_2d_filter) {
    const real ratio = (g.a0 * g.c0 - g.b0 * g.b0) / g.det;
    g.comp_floored = !(ratio > kMinMipRatio);
    g.comp = std::sqrt(g.comp_floored ? kMinMipRatio : ratio);
  }
  return true;
}

inline real sigmoid(real x) { return 1.0f / (1.0f + std::exp(-x)); }

}  // namespace

void project_backward(int64_t n, const float* means, const float* log_scales, const float* quats,
                      const float* opacity_logits, const int32_t* radii, const Viewpoint& view,
                      const ProjectedGrads& gin, float* d_means, float* d_log_scales, float* d_quats,
                      float* d_opacity_logits) {
  const ViewF v(view);
// Dynamic: only the Gaussians that received a gradient cost anything, and a Z-ordered field keeps them in
// runs (each row is independent, so the split does not change any result).
#pragma omp parallel for schedule(dynamic, 512)
  for (int64_t i = 0; i < n; ++i) {
    float* dm = d_means + 3 * i;
    float* dls = d_log_scales + 3 * i;
    float* dq = d_quats + 4 * i;
    dm[0] = dm[1] = dm[2] = 0;
    dls[0] = dls[1] = dls[2] = 0;
    dq[0] = dq[1] = dq[2] = dq[3] = 0;
    d_opacity_logits[i] = 0;
    // Splats hidden behind others get no gradient at all: common (most of a dense field), and cheap to skip.
    const bool any = gin.xy[2 * i] != 0 || gin.xy[2 * i + 1] != 0 || gin.conic[3 * i] != 0 ||
                     gin.conic[3 * i + 1] != 0 || gin.conic[3 * i + 2] != 0 || gin.opacity[i] != 0 ||
                     gin.depth[i] != 0;
    Geometry g;
    if (!any || radii[i] == 0 || !compute_geometry(means + 3 * i, log_scales + 3 * i, quats + 4 * i, v, g)) continue;
    const real z = g.p[2];

    // Opacity: o = sigmoid(logit)·comp.
    const real sig = sigmoid(opacity_logits[i]);
    const real g_op = gin.opacity[i];
    d_opacity_logits[i] = static_cast<float>(g_op * g.comp * sig * (1 - sig));
    const real d_comp = g_op * sig;

    // Conic (A, B, C) = (c, −b, a)/det of the dilated Σ2' = [[a, b], [b, c]].
    const real gA = gin.conic[3 * i], gB = gin.conic[3 * i + 1], gC = gin.conic[3 * i + 2];
    const real a = g.a, b = g.b, c = g.c, det2 = g.det * g.det;
    real da = (-gA * c * c + gB * b * c - gC * b * b) / det2;
    real db = (2 * gA * b * c - gB * (a * c + b * b) + 2 * gC * a * b) / det2;
    real dc = (-gA * b * b + gB * a * b - gC * a * a) / det2;
    if (v.mip_2d_filter && !g.comp_floored) {
      // comp = √(det0 / det), det0 = a0·c0 − b0², det = (a0 + h)(c0 + h) − b0².
      const real det0 = g.a0 * g.c0 - g.b0 * g.b0;
      const real k = d_comp / (2 * g.comp * det2);
      da += k * (g.c0 * g.det - det0 * c);
      dc += k * (g.a0 * g.det - det0 * a);
      db += k * 2 * g.b0 * (det0 - g.det);
    }
    // Σ2 = T Σ Tᵀ with symmetric gradient G2 = [[da, db/2], [db/2, dc]].
    const real G2[4] = {da, 0.5f * db, 0.5f * db, dc};
    real dSigma[9];
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 3; ++k) {
        const real t0r = g.T[r], t1r = g.T[3 + r], t0k = g.T[k], t1k = g.T[3 + k];
        dSigma[3 * r + k] = t0r * (G2[0] * t0k + G2[1] * t1k) + t1r * (G2[2] * t0k + G2[3] * t1k);
      }
    // dL/dT = 2·G2·T·Σ.
    real TS[6];
    for (int r = 0; r < 2; ++r)
      for (int k = 0; k < 3; ++k)
        TS[3 * r + k] = g.T[3 * r] * g.Sigma[k] + g.T[3 * r + 1] * g.Sigma[3 + k] + g.T[3 * r + 2] * g.Sigma[6 + k];
    real dT[6];
    for (int r = 0; r < 2; ++r)
      for (int k = 0; k < 3; ++k) dT[3 * r + k] = 2 * (G2[2 * r] * TS[k] + G2[2 * r + 1] * TS[3 + k]);
    // T = J·W  →  dJ = dT·Wᵀ; only J00, J02, J11, J12 are non-zero.
    const real* W = v.R;
    auto dJ = [&](int r, int k) { return dT[3 * r] * W[3 * k] + dT[3 * r + 1] * W[3 * k + 1] + dT[3 * r + 2] * W[3 * k + 2]; };
    const real dJ00 = dJ(0, 0), dJ02 = dJ(0, 2), dJ11 = dJ(1, 1), dJ12 = dJ(1, 2);
    real dp[3] = {0, 0, 0};
    // J00 = fx/z, J02 = −fx·rx/z (rx the clamped x/z), likewise for y.
    dp[2] += -dJ00 * v.fx / (z * z) - dJ11 * v.fy / (z * z);
    dp[0] += dJ02 * (-v.fx / z) * g.drx_dx;
    dp[2] += dJ02 * (v.fx * g.rx / (z * z) - v.fx / z * g.drx_dz);
    dp[1] += dJ12 * (-v.fy / z) * g.dry_dy;
    dp[2] += dJ12 * (v.fy * g.ry / (z * z) - v.fy / z * g.dry_dz);
    // Projected mean and depth.
    const real gu = gin.xy[2 * i], gv = gin.xy[2 * i + 1];
    dp[0] += gu * v.fx / z;
    dp[1] += gv * v.fy / z;
    dp[2] += -gu * v.fx * g.p[0] / (z * z) - gv * v.fy * g.p[1] / (z * z) + gin.depth[i];
    for (int k = 0; k < 3; ++k) dm[k] = static_cast<float>(W[k] * dp[0] + W[3 + k] * dp[1] + W[6 + k] * dp[2]);

    // Σ = M Mᵀ → dM = 2·dΣ·M (dΣ symmetric); M = Rq·S.
    real dRq[9];
    for (int k = 0; k < 3; ++k) {
      real ds = 0;
      for (int r = 0; r < 3; ++r) {
        const real dM = 2 * (dSigma[3 * r] * g.M[k] + dSigma[3 * r + 1] * g.M[3 + k] + dSigma[3 * r + 2] * g.M[6 + k]);
        dRq[3 * r + k] = dM * g.s[k];
        ds += dM * g.Rq[3 * r + k];
      }
      dls[k] = static_cast<float>(ds * g.s[k]);
    }
    const real qw = g.qn[0], qx = g.qn[1], qy = g.qn[2], qz = g.qn[3];
    const real* G = dRq;
    real dqn[4];
    dqn[0] = 2 * qz * (G[3] - G[1]) + 2 * qy * (G[2] - G[6]) + 2 * qx * (G[7] - G[5]);
    dqn[1] = 2 * qy * (G[1] + G[3]) + 2 * qz * (G[2] + G[6]) + 2 * qw * (G[7] - G[5]) - 4 * qx * (G[4] + G[8]);
    dqn[2] = 2 * qx * (G[1] + G[3]) + 2 * qw * (G[2] - G[6]) + 2 * qz * (G[5] + G[7]) - 4 * qy * (G[0] + G[8]);
    dqn[3] = 2 * qw * (G[3] - G[1]) + 2 * qx * (G[2] + G[6]) + 2 * qy * (G[5] + G[7]) - 4 * qz * (G[0] + G[4]);
    const real dot = qw * dqn[0] + qx * dqn[1] + qy * dqn[2] + qz * dqn[3];
    for (int k = 0; k < 4; ++k) dq[k] = static_cast<float>((dqn[k] - g.qn[k] * dot) / g.qlen);
  }
}

}  // namespace lrf::splat
