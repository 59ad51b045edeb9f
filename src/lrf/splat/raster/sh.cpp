#include "lrf/splat/raster/sh.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace lrf::splat {
namespace {

constexpr float kC0 = 0.28209479177387814f;
constexpr float kC1 = 0.4886025119029199f;
constexpr float kC2[5] = {1.0925484305920792f, -1.0925484305920792f, 0.31539156525252005f,
                          -1.0925484305920792f, 0.5462742152960396f};
constexpr float kC3[7] = {-0.5900435899266435f, 2.890611442640554f, -0.4570457994644658f, 0.3731763325901154f,
                          -0.4570457994644658f, 1.445305721320277f, -0.5900435899266435f};
constexpr int kMaxCoeffs = 16;

// Gradient of each basis function w.r.t. the (unit) direction: grad[k] = ∂b_k/∂(x, y, z).
void sh_basis_grad(int degree, const float d[3], float (*grad)[3]) {
  const float x = d[0], y = d[1], z = d[2];
  grad[0][0] = grad[0][1] = grad[0][2] = 0;
  if (degree < 1) return;
  auto set = [&](int k, float gx, float gy, float gz) { grad[k][0] = gx, grad[k][1] = gy, grad[k][2] = gz; };
  set(1, 0, -kC1, 0);
  set(2, 0, 0, kC1);
  set(3, -kC1, 0, 0);
  if (degree < 2) return;
  const float xx = x * x, yy = y * y, zz = z * z;
  set(4, kC2[0] * y, kC2[0] * x, 0);
  set(5, 0, kC2[1] * z, kC2[1] * y);
  set(6, -2 * kC2[2] * x, -2 * kC2[2] * y, 4 * kC2[2] * z);
  set(7, kC2[3] * z, 0, kC2[3] * x);
  set(8, 2 * kC2[4] * x, -2 * kC2[4] * y, 0);
  if (degree < 3) return;
  set(9, kC3[0] * 6 * x * y, kC3[0] * (3 * xx - 3 * yy), 0);
  set(10, kC3[1] * y * z, kC3[1] * x * z, kC3[1] * x * y);
  set(11, kC3[2] * -2 * x * y, kC3[2] * (4 * zz - xx - 3 * yy), kC3[2] * 8 * y * z);
  set(12, kC3[3] * -6 * x * z, kC3[3] * -6 * y * z, kC3[3] * (6 * zz - 3 * xx - 3 * yy));
  set(13, kC3[4] * (4 * zz - 3 * xx - yy), kC3[4] * -2 * x * y, kC3[4] * 8 * x * z);
  set(14, kC3[5] * 2 * x * z, kC3[5] * -2 * y * z, kC3[5] * (xx - yy));
  set(15, kC3[6] * (3 * xx - 3 * yy), kC3[6] * -6 * x * y, 0);
}

// Unit view direction; returns the length of mean − campos (0 when they coincide).
inline float view_direction(const float* mean, const double campos[3], float d[3]) {
  const double v[3] = {mean[0] - campos[0], mean[1] - campos[1], mean[2] - campos[2]};
  const double len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  for (int k = 0; k < 3; ++k) d[k] = len > 0 ? static_cast<float>(v[k] / len) : 0.f;
  return static_cast<float>(len);
}

template <int kC>
void color_of(int64_t i, int k_stored, int channels, int degree, const float* sh, const float* means,
              const double campos[3], float* out) {
  const int C = kC > 0 ? kC : channels;
  const int K = (degree + 1) * (degree + 1);
  float d[3], b[kMaxCoeffs];
  view_direction(means + 3 * i, campos, d);
  sh_basis(degree, d, b);
  const float* coeffs = sh + i * k_stored * C;
  for (int c = 0; c < C; ++c) out[c] = 0.5f;
  for (int k = 0; k < K; ++k) {
    const float* row = coeffs + k * C;
    for (int c = 0; c < C; ++c) out[c] += b[k] * row[c];
  }
  for (int c = 0; c < C; ++c) out[c] = std::max(out[c], 0.f);
}

template <int kC>
void forward_impl(int64_t n, int k_stored, int channels, int degree, const float* sh, const float* means,
                  const double campos[3], const int32_t* radii, float* colors) {
  const int C = kC > 0 ? kC : channels;
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    if (radii[i] == 0)
      std::fill(colors + i * C, colors + (i + 1) * C, 0.f);
    else
      color_of<kC>(i, k_stored, channels, degree, sh, means, campos, colors + i * C);
  }
}

// One Gaussian's SH gradient into dsh (zeroed by the caller; left zero when no colour gradient reaches it)
// and its view-direction term into d_means.
template <int kC>
inline void row_gradient(int64_t i, int channels, int K, int degree, const float* coeffs, const float* means,
                         const double campos[3], const int32_t* radii, const float* colors, const float* d_colors,
                         const uint8_t* evaluated, float* gc, float* dsh, float* d_means) {
  const int C = kC > 0 ? kC : channels;
  if (radii[i] == 0 || (evaluated && evaluated[i] != 2)) return;
  // Colours clamped at 0 pass no gradient (3DGS); a stored colour > 0 means the clamp was inactive.
  const float* col = colors + i * C;
  const float* dcol = d_colors + i * C;
  bool any = false;
  for (int c = 0; c < C; ++c) {
    gc[c] = col[c] > 0 ? dcol[c] : 0.f;
    any |= gc[c] != 0;
  }
  if (!any) return;
  float d[3], b[kMaxCoeffs], grad[kMaxCoeffs][3];
  const float len = view_direction(means + 3 * i, campos, d);
  sh_basis(degree, d, b);
  float dd[3] = {0, 0, 0};
  if (degree > 0) sh_basis_grad(degree, d, grad);
  for (int k = 0; k < K; ++k) {
    const float* row = coeffs + k * C;
    float* drow = dsh + k * C;
    float w = 0;
    for (int c = 0; c < C; ++c) {
      drow[c] = b[k] * gc[c];
      w += row[c] * gc[c];
    }
    if (k > 0)
      for (int j = 0; j < 3; ++j) dd[j] += w * grad[k][j];
  }
  if (degree > 0 && len > 0) {
    // d = v/|v|: dL/dv = (dL/dd − d·(d·dL/dd)) / |v|.
    const float dot = d[0] * dd[0] + d[1] * dd[1] + d[2] * dd[2];
    for (int j = 0; j < 3; ++j) d_means[3 * i + j] += (dd[j] - d[j] * dot) / len;
  }
}

template <int kC>
void backward_impl(int64_t n, int k_stored, int channels, int degree, const float* sh, const float* means,
                   const double campos[3], const int32_t* radii, const float* colors, const float* d_colors,
                   float* d_sh, float* d_means, const uint8_t* evaluated, const ShGradientSink* sink) {
  const int C = kC > 0 ? kC : channels;
  const int K = (degree + 1) * (degree + 1);
  const int64_t row_size = static_cast<int64_t>(k_stored) * C;
#pragma omp parallel
  {
    std::vector<float> gc_buf(C), row_buf(sink ? row_size : 0);
    float* gc = gc_buf.data();
    // Dynamic: only the Gaussians whose colour was used cost anything, and a Z-ordered field keeps them in
    // runs (each row is independent, so the split does not change any result).
#pragma omp for schedule(dynamic, 512)
    for (int64_t i = 0; i < n; ++i) {
      float* dsh = sink ? row_buf.data() : d_sh + i * row_size;
      std::fill(dsh, dsh + row_size, 0.f);
      row_gradient<kC>(i, C, K, degree, sh + i * row_size, means, campos, radii, colors, d_colors, evaluated, gc,
                       dsh, d_means);
      if (sink) sink->consume(sink->context, i, dsh);
    }
  }
}

}  // namespace

void sh_basis(int degree, const float d[3], float* b) {
  const float x = d[0], y = d[1], z = d[2];
  b[0] = kC0;
  if (degree < 1) return;
  b[1] = -kC1 * y;
  b[2] = kC1 * z;
  b[3] = -kC1 * x;
  if (degree < 2) return;
  const float xx = x * x, yy = y * y, zz = z * z;
  b[4] = kC2[0] * x * y;
  b[5] = kC2[1] * y * z;
  b[6] = kC2[2] * (2 * zz - xx - yy);
  b[7] = kC2[3] * x * z;
  b[8] = kC2[4] * (xx - yy);
  if (degree < 3) return;
  b[9] = kC3[0] * y * (3 * xx - yy);
  b[10] = kC3[1] * x * y * z;
  b[11] = kC3[2] * y * (4 * zz - xx - yy);
  b[12] = kC3[3] * z * (2 * zz - 3 * xx - 3 * yy);
  b[13] = kC3[4] * x * (4 * zz - xx - yy);
  b[14] = kC3[5] * z * (xx - yy);
  b[15] = kC3[6] * x * (xx - 3 * yy);
}

// Channel counts of the product (RGB, SD latents, TAE latents) get loops with a compile-time trip count.
#define LRF_SH_DISPATCH(FN, ...)                 \
  switch (channels) {                            \
    case 1: FN<1>(__VA_ARGS__); break;           \
    case 3: FN<3>(__VA_ARGS__); break;           \
    case 4: FN<4>(__VA_ARGS__); break;           \
    case 16: FN<16>(__VA_ARGS__); break;         \
    case 32: FN<32>(__VA_ARGS__); break;         \
    default: FN<0>(__VA_ARGS__); break;          \
  }

void sh_forward(int64_t n, int k_stored, int channels, int degree, const float* sh, const float* means,
                const double campos[3], const int32_t* radii, float* colors) {
  LRF_SH_DISPATCH(forward_impl, n, k_stored, channels, degree, sh, means, campos, radii, colors)
}

void sh_forward_one(int64_t i, int k_stored, int channels, int degree, const float* sh, const float* means,
                    const double campos[3], float* color) {
  LRF_SH_DISPATCH(color_of, i, k_stored, channels, degree, sh, means, campos, color)
}

void sh_backward(int64_t n, int k_stored, int channels, int degree, const float* sh, const float* means,
                 const double campos[3], const int32_t* radii, const float* colors, const float* d_colors,
                 float* d_sh, float* d_means, const uint8_t* evaluated, const ShGradientSink* sink) {
  LRF_SH_DISPATCH(backward_impl, n, k_stored, channels, degree, sh, means, campos, radii, colors, d_colors, d_sh,
                  d_means, evaluated, sink)
}

#undef LRF_SH_DISPATCH

}  // namespace lrf::splat
