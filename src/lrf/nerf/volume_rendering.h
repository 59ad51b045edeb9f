#pragma once
// Volume rendering along rays (NeRF's quadrature): every ray has S samples sorted front to back, each with
// a density σ ≥ 0, an interval length δ and a C-channel value c. With τ_i = σ_i δ_i,
//   α_i = 1 − exp(−τ_i),  T_i = exp(−Σ_{j<i} τ_j),  w_i = T_i α_i,
//   out = Σ_i w_i c_i + T_S · background.
// Gradients, with g = ∂L/∂out:
//   ∂L/∂c_i = w_i g,   ∂L/∂σ_i = δ_i · (T_{i+1} g·c_i − Σ_{j>i} w_j g·c_j − T_S g·background)
// (every later sample and the background lose what sample i absorbs). No sample is skipped: the result
// is exactly the formula, for training and for rendering alike.
#include <cstdint>

namespace lrf::nerf {

// sigma, delta: [rays, S]; values: [rays, S, C]; background: [C]; out: [rays, C]; weights (optional,
// may be null): [rays, S]; transmittance (optional): [rays] (T_S, what reaches the background).
void composite_forward(const float* sigma, const float* delta, const float* values, const float* background,
                       int64_t rays, int samples, int channels, float* out, float* weights, float* transmittance);

// The weights w_i alone (for choosing where to sample next): sigma, delta [rays, S] -> weights [rays, S].
void composite_weights(const float* sigma, const float* delta, int64_t rays, int samples, float* weights);

// Given d_out = ∂L/∂out [rays, C] and the forward's inputs, writes d_sigma [rays, S] and d_values
// [rays, S, C] (overwritten, not accumulated).
void composite_backward(const float* sigma, const float* delta, const float* values, const float* background,
                        const float* d_out, int64_t rays, int samples, int channels, float* d_sigma,
                        float* d_values);

}  // namespace lrf::nerf
