#include "lrf/autoencoder/strict_load.h"

#include <set>
#include <sstream>

#include <torch/torch.h>

#include "lrf/core/error.h"

namespace lrf {
namespace {

std::string shape_string(at::IntArrayRef s) {
  std::ostringstream o;
  o << "[";
  for (std::size_t i = 0; i < s.size(); ++i) o << (i ? "," : "") << s[i];
  o << "]";
  return o.str();
}

// At most `limit` names, then a count, so that the message stays one readable line.
std::string list(const std::vector<std::string>& names, std::size_t limit = 12) {
  std::ostringstream o;
  for (std::size_t i = 0; i < names.size() && i < limit; ++i) o << (i ? ", " : "") << names[i];
  if (names.size() > limit) o << ", ... (" << names.size() - limit << " more)";
  return o.str();
}

}  // namespace

namespace {

torch::OrderedDict<std::string, at::Tensor> targets_of(torch::nn::Module& module) {
  auto targets = module.named_parameters(true);
  for (const auto& b : module.named_buffers(true)) targets.insert(b.key(), b.value());
  return targets;
}

}  // namespace

std::string strict_mismatch(torch::nn::Module& module, const StateDict& weights) {
  auto targets = targets_of(module);
  std::vector<std::string> missing, unexpected, misshaped;
  for (const auto& t : targets) {
    const at::Tensor* w = weights.find(t.key());
    if (!w) {
      missing.push_back(t.key());
    } else if (w->sizes() != t.value().sizes()) {
      misshaped.push_back(t.key() + " " + shape_string(w->sizes()) + " (expected " +
                          shape_string(t.value().sizes()) + ")");
    }
  }
  for (const auto& w : weights)
    if (!targets.contains(w.key())) unexpected.push_back(w.key());
  std::string msg;
  if (!missing.empty()) msg += " missing " + std::to_string(missing.size()) + " keys: " + list(missing) + ";";
  if (!unexpected.empty())
    msg += " unexpected " + std::to_string(unexpected.size()) + " keys: " + list(unexpected) + ";";
  if (!misshaped.empty()) msg += " wrong shape: " + list(misshaped) + ";";
  return msg.empty() ? msg : msg.substr(1);
}

void load_strict(torch::nn::Module& module, const StateDict& weights, const std::string& what) {
  std::string mismatch = strict_mismatch(module, weights);
  if (!mismatch.empty()) fail(what, "weights do not fit the architecture: " + mismatch);
  auto targets = targets_of(module);
  torch::NoGradGuard no_grad;
  for (auto& t : targets) {
    at::Tensor src = weights[t.key()].to(t.value().scalar_type());
    if (!src.isfinite().all().item<bool>()) fail(what, "tensor " + t.key() + " holds NaN or infinity");
    t.value().copy_(src);
  }
}

StateDict module_state(const torch::nn::Module& module) {
  StateDict out;
  for (const auto& p : module.named_parameters(true)) {
    out.insert(p.key(), p.value().detach().to(torch::kFloat).contiguous().clone());
  }
  for (const auto& b : module.named_buffers(true)) {
    out.insert(b.key(), b.value().detach().to(torch::kFloat).contiguous().clone());
  }
  return out;
}

}  // namespace lrf
