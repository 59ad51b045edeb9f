#include "lrf/optim/param_adam.h"

#include <cmath>

#include <torch/torch.h>

#include "lrf/core/error.h"
#include "lrf/core/safetensors.h"

namespace lrf {

namespace {

// p -= lr / bc1 * m / (sqrt(v / bc2) + eps) after the moments' update, in one pass over float32 tensors.
void fused_update(at::Tensor& param, const at::Tensor& grad, at::Tensor& m, at::Tensor& v, const AdamOptions& o,
                  double bc1, double bc2, bool lazy) {
  float* p = param.data_ptr<float>();
  const float* g = grad.data_ptr<float>();
  float* mp = m.data_ptr<float>();
  float* vp = v.data_ptr<float>();
  const float step_size = static_cast<float>(o.lr / bc1), inv_bc2 = static_cast<float>(1.0 / bc2);
  const float b1 = static_cast<float>(o.beta1), b2 = static_cast<float>(o.beta2), eps = static_cast<float>(o.eps);
  at::parallel_for(0, param.numel(), 1 << 14, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) {
      if (lazy && g[i] == 0.0f) continue;
      mp[i] = b1 * mp[i] + (1.0f - b1) * g[i];
      vp[i] = b2 * vp[i] + (1.0f - b2) * g[i] * g[i];
      p[i] -= step_size * mp[i] / (std::sqrt(vp[i] * inv_bc2) + eps);
    }
  });
}

bool fusable(const at::Tensor& param, const at::Tensor& grad) {
  return param.scalar_type() == at::kFloat && grad.scalar_type() == at::kFloat && param.is_contiguous() &&
         grad.is_contiguous();
}

}  // namespace

ParamAdam::ParamAdam(std::vector<at::Tensor> params, AdamOptions options, std::vector<bool> lazy)
    : params_(std::move(params)), lazy_(std::move(lazy)), options_(options) {
  if (lazy_.empty()) lazy_.assign(params_.size(), false);
  if (lazy_.size() != params_.size()) fail("ParamAdam: one lazy flag per parameter expected");
  for (const auto& p : params_) {
    m_.push_back(torch::zeros_like(p));
    v_.push_back(torch::zeros_like(p));
  }
}

std::vector<at::Tensor> ParamAdam::state_tensors() const {
  std::vector<at::Tensor> all = params_;
  all.insert(all.end(), m_.begin(), m_.end());
  all.insert(all.end(), v_.begin(), v_.end());
  return all;
}

void ParamAdam::zero_grad() {
  for (auto& p : params_) {
    if (p.grad().defined()) p.mutable_grad() = at::Tensor();
  }
}

void ParamAdam::step() {
  std::vector<at::Tensor> grads;
  for (const auto& p : params_) grads.push_back(p.grad());
  step(grads);
}

void ParamAdam::step(const std::vector<at::Tensor>& grads) {
  if (grads.size() != params_.size()) fail("ParamAdam: one gradient per parameter expected");
  torch::NoGradGuard no_grad;
  ++steps_;
  const double bc1 = 1.0 - std::pow(options_.beta1, static_cast<double>(steps_));
  const double bc2 = 1.0 - std::pow(options_.beta2, static_cast<double>(steps_));
  for (size_t i = 0; i < params_.size(); ++i) {
    const at::Tensor& g = grads[i];
    if (!g.defined()) continue;
    if (g.sizes() != params_[i].sizes()) fail("ParamAdam: a gradient's shape differs from its parameter's");
    if (fusable(params_[i], g)) {
      fused_update(params_[i], g, m_[i], v_[i], options_, bc1, bc2, lazy_[i]);
      // Written through its data pointer, which autograd does not see: caches keyed by the version (the
      // fused autoencoder's packed weights, tiny_fused.cpp) must see the change as after an in-place op.
      params_[i].unsafeGetTensorImpl()->bump_version();
      continue;
    }
    at::Tensor m_new = m_[i] * options_.beta1 + g * (1.0 - options_.beta1);
    at::Tensor v_new = v_[i] * options_.beta2 + g * g * (1.0 - options_.beta2);
    at::Tensor update = m_new * (-options_.lr / bc1) / ((v_new / bc2).sqrt() + options_.eps);
    if (lazy_[i]) {
      const at::Tensor keep = g != 0;
      m_new = at::where(keep, m_new, m_[i]);
      v_new = at::where(keep, v_new, v_[i]);
      update = at::where(keep, update, at::zeros_like(update));
    }
    m_[i].copy_(m_new);
    v_[i].copy_(v_new);
    params_[i].add_(update.to(params_[i].scalar_type()));
  }
}

void ParamAdam::save(const std::string& path, const std::map<std::string, std::string>& metadata) const {
  StateDict out;
  for (size_t i = 0; i < params_.size(); ++i) {
    const std::string k = std::to_string(i);
    out.insert("param." + k, params_[i].detach().contiguous());
    out.insert("adam.m." + k, m_[i].contiguous());
    out.insert("adam.v." + k, v_[i].contiguous());
  }
  auto meta = metadata;
  meta["lrf_adam_steps"] = std::to_string(steps_);
  meta["lrf_adam_params"] = std::to_string(params_.size());
  write_safetensors(path, out, meta);
}

std::map<std::string, std::string> ParamAdam::load(const std::string& path) {
  StateDict in = read_safetensors(path);
  auto meta = read_safetensors_metadata(path);
  auto count = meta.find("lrf_adam_params");
  auto steps = meta.find("lrf_adam_steps");
  if (count == meta.end() || steps == meta.end()) fail(path, "not an lrf fine-tuning checkpoint (no optimizer state)");
  if (count->second != std::to_string(params_.size())) {
    fail(path, "checkpoint holds " + count->second + " parameters but the model has " +
                   std::to_string(params_.size()) + " (a different autoencoder?)");
  }
  torch::NoGradGuard no_grad;
  for (size_t i = 0; i < params_.size(); ++i) {
    const std::string k = std::to_string(i);
    for (auto [name, target] : {std::pair{"param." + k, &params_[i]}, std::pair{"adam.m." + k, &m_[i]},
                                std::pair{"adam.v." + k, &v_[i]}}) {
      const at::Tensor* t = in.find(name);
      if (!t) fail(path, "missing tensor '" + name + "'");
      if (t->sizes() != target->sizes()) fail(path, "tensor '" + name + "' has the wrong shape for this model");
      if (!torch::isfinite(*t).all().item<bool>()) fail(path, "tensor '" + name + "' holds NaN or infinite values");
      target->copy_(t->to(target->scalar_type()));
    }
  }
  try {
    steps_ = std::stoll(steps->second);
  } catch (const std::exception&) {
    fail(path, "bad step count '" + steps->second + "'");
  }
  return meta;
}

}  // namespace lrf
