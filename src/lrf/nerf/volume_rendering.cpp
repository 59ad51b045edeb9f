#include "lrf/nerf/volume_rendering.h"

#include <cmath>
#include <vector>

#include <ATen/Parallel.h>

namespace lrf::nerf {

void composite_forward(const float* sigma, const float* delta, const float* values, const float* background,
                       int64_t rays, int samples, int channels, float* out, float* weights, float* transmittance) {
  const int S = samples, C = channels;
  at::parallel_for(0, rays, 64, [&](int64_t begin, int64_t end) {
    for (int64_t r = begin; r < end; ++r) {
      float* o = out + r * C;
      for (int c = 0; c < C; ++c) o[c] = 0.0f;
      // Transmittance as the exponential of the summed optical depth (not a running product of 1 − α):
      // the same value the backward pass recomputes.
      double depth = 0.0;
      for (int i = 0; i < S; ++i) {
        const int64_t k = r * S + i;
        const double tau = double(sigma[k]) * double(delta[k]);
        const float w = static_cast<float>(std::exp(-depth) * -std::expm1(-tau));
        depth += tau;
        if (weights) weights[k] = w;
        const float* v = values + k * C;
        for (int c = 0; c < C; ++c) o[c] += w * v[c];
      }
      const float t_end = static_cast<float>(std::exp(-depth));
      for (int c = 0; c < C; ++c) o[c] += t_end * background[c];
      if (transmittance) transmittance[r] = t_end;
    }
  });
}

void composite_weights(const float* sigma, const float* delta, int64_t rays, int samples, float* weights) {
  at::parallel_for(0, rays, 256, [&](int64_t begin, int64_t end) {
    for (int64_t r = begin; r < end; ++r) {
      double depth = 0.0;
      for (int i = 0; i < samples; ++i) {
        const int64_t k = r * samples + i;
        const double tau = double(sigma[k]) * double(delta[k]);
        weights[k] = static_cast<float>(std::exp(-depth) * -std::expm1(-tau));
        depth += tau;
      }
    }
  });
}

void composite_backward(const float* sigma, const float* delta, const float* values, const float* background,
                        const float* d_out, int64_t rays, int samples, int channels, float* d_sigma,
                        float* d_values) {
  const int S = samples, C = channels;
  at::parallel_for(0, rays, 64, [&](int64_t begin, int64_t end) {
    std::vector<double> w(static_cast<size_t>(S)), t_after(static_cast<size_t>(S)), g_value(static_cast<size_t>(S));
    for (int64_t r = begin; r < end; ++r) {
      const float* g = d_out + r * C;
      double depth = 0.0;
      for (int i = 0; i < S; ++i) {
        const int64_t k = r * S + i;
        const double tau = double(sigma[k]) * double(delta[k]);
        w[i] = std::exp(-depth) * -std::expm1(-tau);
        depth += tau;
        t_after[i] = std::exp(-depth);
        const float* v = values + k * C;
        float* dv = d_values + k * C;
        double gv = 0.0;
        for (int c = 0; c < C; ++c) {
          gv += double(g[c]) * double(v[c]);
          dv[c] = static_cast<float>(w[i]) * g[c];
        }
        g_value[i] = gv;
      }
      // What lies behind sample i (later samples and the background), summed from the back rather than as
      // out minus the front part: with the last interval's huge δ, a difference's rounding error times δ
      // would swamp the (vanishing) true gradient.
      double behind = 0.0;
      for (int c = 0; c < C; ++c) behind += double(g[c]) * double(background[c]);
      behind *= std::exp(-depth);
      for (int i = S - 1; i >= 0; --i) {
        const int64_t k = r * S + i;
        d_sigma[k] = static_cast<float>(double(delta[k]) * (t_after[i] * g_value[i] - behind));
        behind += w[i] * g_value[i];
      }
    }
  });
}

}  // namespace lrf::nerf
