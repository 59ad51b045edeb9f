#include "lrf/optim/param_adam.h"

#include <cmath>

#include <torch/torch.h>

#include "lrf/core/error.h"
#include "lrf/core/safetensors.h"

namespace lrf {

ParamAdam::ParamAdam(std::vector<at::Tensor> params, AdamOptions options)
    : params_(std::move(params)), options_(options) {
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
  torch::NoGradGuard no_grad;
  ++steps_;
  const double bc1 = 1.0 - std::pow(options_.beta1, static_cast<double>(steps_));
  const double bc2 = 1.0 - std::pow(options_.beta2, static_cast<double>(steps_));
  const double step_size = options_.lr / bc1;
  const double sqrt_bc2 = std::sqrt(bc2);
  for (size_t i = 0; i < params_.size(); ++i) {
    const at::Tensor& g = params_[i].grad();
    if (!g.defined()) continue;
    m_[i].mul_(options_.beta1).add_(g, 1.0 - options_.beta1);
    v_[i].mul_(options_.beta2).addcmul_(g, g, 1.0 - options_.beta2);
    at::Tensor denom = (v_[i].sqrt() / sqrt_bc2).add_(options_.eps);
    params_[i].addcdiv_(m_[i], denom, -step_size);
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
