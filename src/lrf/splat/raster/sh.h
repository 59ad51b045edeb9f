#pragma once
// Real spherical harmonics up to degree 3 for C channels, with the constants and sign conventions of 3DGS,
// and the backward (w.r.t. the coefficients and, through the view direction, the means).
#include <cstdint>

namespace lrf::splat {

// Basis values b[0..(degree+1)²) for a unit direction d, in 3DGS order.
void sh_basis(int degree, const float d[3], float* b);

// colors[i, c] = max(Σ_k b_k(dir_i)·sh[i, k, c] + 0.5, 0), dir_i = normalize(mean_i − campos), for the
// Gaussians with radii > 0 (zeros elsewhere). sh holds k_stored >= (degree+1)² coefficients per Gaussian.
void sh_forward(int64_t n, int k_stored, int channels, int degree, const float* sh, const float* means,
                const double campos[3], const int32_t* radii, float* colors);

// The colour of Gaussian i alone, as sh_forward computes it (the rasterizer evaluates colours on first use).
void sh_forward_one(int64_t i, int k_stored, int channels, int degree, const float* sh, const float* means,
                    const double campos[3], float* color);

// Takes each Gaussian's SH gradient row ([k_stored, C] floats) as soon as the backward has it, in place of
// an [N, k_stored, C] gradient tensor: a training step's optimizer applies it while the row is in cache
// (GaussianAdam::sh_row_update). consume is called once for every row in [0, N), zero rows included, from
// the backward's threads; the row of `sh` it is given may be changed by it (the backward has read it).
struct ShGradientSink {
  void (*consume)(void* context, int64_t row, const float* d_row) = nullptr;
  void* context = nullptr;
};

// d_sh (overwritten, [N, k_stored, C]; zeros for inactive degrees and culled Gaussians) and d_means
// (accumulated into: the projection writes its part first). The clamp at 0 passes no gradient. When
// `evaluated` is given, only Gaussians with evaluated[i] == 2 have a colour (the others get zeros).
// With a sink, d_sh is not written (it may be null) and each row goes to the sink instead.
void sh_backward(int64_t n, int k_stored, int channels, int degree, const float* sh, const float* means,
                 const double campos[3], const int32_t* radii, const float* colors, const float* d_colors,
                 float* d_sh, float* d_means, const uint8_t* evaluated = nullptr,
                 const ShGradientSink* sink = nullptr);

}  // namespace lrf::splat
