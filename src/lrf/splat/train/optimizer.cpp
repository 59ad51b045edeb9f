#include "lrf/splat/train/optimizer.h"

#include <immintrin.h>

#include <cmath>

#include <ATen/ATen.h>
#include <ATen/Parallel.h>

#include "lrf/core/cpu_features.h"
#include "lrf/core/error.h"

namespace lrf::splat {
namespace {

// The update of element i, shared by the scalar loop and the vector loop's tail.
inline void adam_element(float* p, const float* g, float* m, float* v, int64_t i, const AdamScalars& s) {
  const float gi = g[i];
  const float mi = s.beta1 * m[i] + s.one_minus_beta1 * gi;
  const float vi = s.beta2 * v[i] + s.one_minus_beta2 * gi * gi;
  m[i] = mi;
  v[i] = vi;
  p[i] -= s.step_size * mi / (std::sqrt(vi) * s.inv_sqrt_bc2 + s.eps);
}

// GCC keeps the scalar loop scalar (std::sqrt may set errno), so the vector loop is written out; at 2
// threads the scalar loop took a third of a latent training step (fern, 44k Gaussians × 139 floats).
__attribute__((target("avx2"))) void adam_update_avx2(float* p, const float* g, float* m, float* v, int64_t n,
                                                       const AdamScalars& s) {
  const __m256 b1 = _mm256_set1_ps(s.beta1), b2 = _mm256_set1_ps(s.beta2);
  const __m256 c1 = _mm256_set1_ps(s.one_minus_beta1), c2 = _mm256_set1_ps(s.one_minus_beta2);
  const __m256 step = _mm256_set1_ps(s.step_size), inv = _mm256_set1_ps(s.inv_sqrt_bc2);
  const __m256 eps = _mm256_set1_ps(s.eps);
  int64_t i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m256 gi = _mm256_loadu_ps(g + i);
    const __m256 mi = _mm256_add_ps(_mm256_mul_ps(b1, _mm256_loadu_ps(m + i)), _mm256_mul_ps(c1, gi));
    const __m256 vi =
        _mm256_add_ps(_mm256_mul_ps(b2, _mm256_loadu_ps(v + i)), _mm256_mul_ps(_mm256_mul_ps(c2, gi), gi));
    _mm256_storeu_ps(m + i, mi);
    _mm256_storeu_ps(v + i, vi);
    const __m256 den = _mm256_add_ps(_mm256_mul_ps(_mm256_sqrt_ps(vi), inv), eps);
    _mm256_storeu_ps(p + i, _mm256_sub_ps(_mm256_loadu_ps(p + i), _mm256_div_ps(_mm256_mul_ps(step, mi), den)));
  }
  for (; i < n; ++i) adam_element(p, g, m, v, i, s);
}

}  // namespace

AdamScalars adam_scalars(double lr, double b1, double b2, double eps, int64_t t) {
  const double bc1 = 1.0 - std::pow(b1, double(t));
  const double bc2 = 1.0 - std::pow(b2, double(t));
  return {float(b1), float(b2), float(1 - b1), float(1 - b2), float(lr / bc1), float(1.0 / std::sqrt(bc2)),
          float(eps)};
}

void adam_update(float* p, const float* g, float* m, float* v, int64_t n, const AdamScalars& s, bool vectorised) {
  if (vectorised && cpu_has_avx2()) return adam_update_avx2(p, g, m, v, n, s);
  for (int64_t i = 0; i < n; ++i) adam_element(p, g, m, v, i, s);
}

double LearningRates::short_run_factor(int64_t iterations) {
  if (iterations >= kInriaShortRunSteps) return 1.0;
  return std::min(kMaxShortRunFactor, double(kInriaShortRunSteps) / double(std::max<int64_t>(iterations, 1)));
}

LearningRates LearningRates::for_short_run(int64_t iterations) const {
  const double k = short_run_factor(iterations);
  LearningRates r = *this;
  r.position_init *= k;
  r.position_final *= k;
  r.sh_dc *= k;
  r.sh_rest *= k;
  return r;
}

GaussianAdam::GaussianAdam(const Gaussians& g, const LearningRates& lr, double extent, int64_t total_steps)
    : lr_(lr), extent_(extent), total_(std::max<int64_t>(total_steps, 1)) {
  auto params = g.parameters();
  for (int i = 0; i < kGroups; ++i) {
    m_[i] = torch::zeros_like(params[i]->detach());
    v_[i] = torch::zeros_like(params[i]->detach());
  }
}

double LearningRates::decay_progress(int64_t step, int64_t total) const {
  const double t = std::clamp(double(step) / double(total), 0.0, 1.0);
  if (decay_start <= 0) return t;
  return std::clamp((t - decay_start) / (1.0 - decay_start), 0.0, 1.0);
}

double GaussianAdam::position_lr(int64_t step) const {
  if (lr_.position_init <= 0 || lr_.position_final <= 0) return 0;  // frozen means (no log of 0)
  const double t = lr_.decay_progress(step, total_);
  return extent_ * std::exp(std::log(lr_.position_init) * (1 - t) + std::log(lr_.position_final) * t);
}

double LearningRates::others_factor(int64_t step, int64_t total) const {
  if (others_final_factor == 1.0) return 1.0;
  return std::exp(std::log(others_final_factor) * decay_progress(step, total));
}

double GaussianAdam::others_factor(int64_t step) const { return lr_.others_factor(step, total_); }

GaussianAdam::GroupRows GaussianAdam::group_rows(const Gaussians& g, int k, int64_t t, int active_sh_degree) const {
  const double f = others_factor(t - 1);
  const double group_lr[kGroups] = {position_lr(t - 1), f * lr_.scales, f * lr_.rotations, f * lr_.opacity,
                                    f * lr_.sh_dc};
  const torch::Tensor& p = *g.parameters()[k];
  GroupRows r;
  const int64_t n = p.size(0);
  r.row = n ? p.numel() / n : 0;
  // For SH: band 0 (C values) at the DC rate, then the active higher bands at the rest rate.
  r.seg0 = r.row;
  r.s0 = r.s1 = adam_scalars(group_lr[k], beta1, beta2, eps, t);
  if (k == 4) {
    const int64_t c = p.size(2);
    r.seg0 = c;
    r.seg1 = (sh_coefficients(active_sh_degree) - 1) * c;
    r.s1 = adam_scalars(f * lr_.sh_rest, beta1, beta2, eps, t);
  }
  return r;
}

void GaussianAdam::update_row(const GroupRows& r, float* p, const float* g, float* m, float* v) {
  adam_update(p, g, m, v, r.seg0, r.s0);
  if (r.seg1) adam_update(p + r.seg0, g + r.seg0, m + r.seg0, v + r.seg0, r.seg1, r.s1);
}

const ShGradientSink& GaussianAdam::sh_row_update(Gaussians& g, int active_sh_degree) {
  if (sparse) fail("GaussianAdam: the row-by-row SH update does not skip rows (sparse Adam)");
  torch::Tensor& p = *g.parameters()[4];
  TORCH_CHECK(p.is_contiguous() && m_[4].sizes() == p.sizes(), "optimizer state out of step with parameters");
  sh_rows_ = group_rows(g, 4, steps_ + 1, active_sh_degree);
  sh_rows_.p = p.data_ptr<float>();
  sh_rows_.m = m_[4].data_ptr<float>();
  sh_rows_.v = v_[4].data_ptr<float>();
  sh_sink_.context = &sh_rows_;
  sh_sink_.consume = [](void* context, int64_t index, const float* grad_row) {
    const auto& r = *static_cast<const GroupRows*>(context);
    const int64_t o = index * r.row;
    update_row(r, r.p + o, grad_row, r.m + o, r.v + o);
  };
  sh_rows_pending_ = true;
  return sh_sink_;
}

void GaussianAdam::step(Gaussians& g, int active_sh_degree, const torch::Tensor& visible) {
  ++steps_;
  auto params = g.parameters();
  const bool use_mask = sparse && visible.defined();
  torch::Tensor mask_u8;
  if (use_mask) mask_u8 = visible.to(torch::kUInt8).contiguous();
  const uint8_t* mask = use_mask ? mask_u8.data_ptr<uint8_t>() : nullptr;
  const bool sh_done = sh_rows_pending_;
  sh_rows_pending_ = false;

  for (int k = 0; k < kGroups; ++k) {
    torch::Tensor& p = *params[k];
    torch::Tensor grad = p.grad();
    if (k == 4 && sh_done) {
      if (grad.defined()) fail("GaussianAdam: an SH gradient arrived beside the row-by-row update; it would be lost");
      continue;
    }
    if (!grad.defined()) continue;
    if (!grad.is_contiguous()) grad = grad.contiguous();
    TORCH_CHECK(p.is_contiguous() && m_[k].sizes() == p.sizes(), "optimizer state out of step with parameters");
    const int64_t n = p.size(0);
    const GroupRows spans = group_rows(g, k, steps_, active_sh_degree);
    const int64_t row = spans.row;
    float* pp = p.data_ptr<float>();
    const float* gp = grad.data_ptr<float>();
    float* mp = m_[k].data_ptr<float>();
    float* vp = v_[k].data_ptr<float>();
    const int64_t grain = std::max<int64_t>(1, 32768 / std::max<int64_t>(row, 1));
    at::parallel_for(0, n, grain, [&](int64_t begin, int64_t end) {
      if (!mask && spans.seg0 == row) {  // whole rows, one segment: one long span
        const int64_t o = begin * row;
        adam_update(pp + o, gp + o, mp + o, vp + o, (end - begin) * row, spans.s0);
        return;
      }
      for (int64_t r = begin; r < end; ++r) {
        if (mask && !mask[r]) continue;
        const int64_t o = r * row;
        update_row(spans, pp + o, gp + o, mp + o, vp + o);
      }
    });
  }
}

void GaussianAdam::gather_rows(const torch::Tensor& source, int64_t first_new) {
  for (int k = 0; k < kGroups; ++k)
    for (auto* t : {&m_[k], &v_[k]}) {
      *t = t->index_select(0, source);
      t->narrow(0, first_new, t->size(0) - first_new).zero_();
    }
}

void GaussianAdam::reset_group(int group) {
  m_[group].zero_();
  v_[group].zero_();
}

std::vector<torch::Tensor> GaussianAdam::state() const {
  std::vector<torch::Tensor> out(m_.begin(), m_.end());
  out.insert(out.end(), v_.begin(), v_.end());
  return out;
}

void GaussianAdam::set_state(const std::vector<torch::Tensor>& tensors, int64_t steps) {
  if (tensors.size() != 2 * kGroups) fail("optimizer state: expected " + std::to_string(2 * kGroups) + " tensors");
  for (int k = 0; k < kGroups; ++k) {
    m_[k] = tensors[k].contiguous().clone();
    v_[k] = tensors[kGroups + k].contiguous().clone();
  }
  steps_ = steps;
}

}  // namespace lrf::splat
