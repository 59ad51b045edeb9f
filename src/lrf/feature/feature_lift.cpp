#include "lrf/feature/feature_lift.h"

#include <cmath>

#include <ATen/ATen.h>
#include <ATen/CPUGeneratorImpl.h>

#include "lrf/core/error.h"
#include "lrf/core/safetensors.h"

namespace lrf {

int default_feature_dim(int latent_channels) { return latent_channels >= 2 ? latent_channels / 2 : 1; }

FeatureLift FeatureLift::initial(int feature_dim, int channels, uint64_t seed) {
  if (feature_dim < 1 || channels < 1) fail("a feature lift needs at least one feature and one output channel");
  auto gen = at::make_generator<at::CPUGeneratorImpl>(seed);
  const double bound = 1.0 / std::sqrt(static_cast<double>(feature_dim));
  FeatureLift l;
  l.weight = (at::rand({channels, feature_dim}, gen, at::kFloat) * 2.0 - 1.0) * bound;
  l.bias = (at::rand({channels}, gen, at::kFloat) * 2.0 - 1.0) * bound;
  l.weight.requires_grad_(true);
  l.bias.requires_grad_(true);
  return l;
}

at::Tensor FeatureLift::apply(const at::Tensor& features) const {
  if (features.dim() != 3 || features.size(0) != feature_dim())
    fail("feature lift: expected features [" + std::to_string(feature_dim()) + ", H, W]");
  const int64_t h = features.size(1), w = features.size(2);
  // One matrix product over all pixels: [C, D] x [D, H*W] + b.
  return at::addmm(bias.unsqueeze(1), weight, features.reshape({feature_dim(), h * w})).view({channels(), h, w});
}

void FeatureLift::save(const std::string& path) const {
  StateDict out;
  out.insert("weight", weight.detach().contiguous());
  out.insert("bias", bias.detach().contiguous());
  write_safetensors(path, out,
                    {{"lrf_kind", "feature-lift"},
                     {"feature_dim", std::to_string(feature_dim())},
                     {"channels", std::to_string(channels())}});
}

FeatureLift FeatureLift::load(const std::string& path, int feature_dim, int channels) {
  StateDict in = read_safetensors(path);
  const auto meta = read_safetensors_metadata(path);
  const auto kind = meta.find("lrf_kind");
  if (kind == meta.end() || kind->second != "feature-lift") fail(path, "not a feature lift (lrf_kind is not feature-lift)");
  FeatureLift l;
  for (auto [name, target, shape] :
       {std::tuple{"weight", &l.weight, std::vector<int64_t>{channels, feature_dim}},
        std::tuple{"bias", &l.bias, std::vector<int64_t>{channels}}}) {
    const at::Tensor* t = in.find(name);
    if (!t) fail(path, std::string("missing tensor '") + name + "'");
    if (t->sizes() != at::IntArrayRef(shape)) {
      fail(path, std::string("tensor '") + name + "' has shape " + c10::str(t->sizes()) + ", the field needs " +
                     c10::str(at::IntArrayRef(shape)));
    }
    if (!t->is_floating_point()) fail(path, std::string("tensor '") + name + "' is not floating point");
    *target = t->to(at::kFloat).contiguous();
    if (!at::isfinite(*target).all().item<bool>())
      fail(path, std::string("tensor '") + name + "' holds NaN or infinite values");
  }
  return l;
}

}  // namespace lrf
