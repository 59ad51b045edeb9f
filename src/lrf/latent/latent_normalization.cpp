#include "lrf/latent/latent_normalization.h"

#include <ATen/ATen.h>

#include "lrf/core/error.h"

namespace lrf {
namespace {

torch::Tensor channel_view(const std::vector<float>& v, const torch::Tensor& like) {
  auto t = at::tensor(v, at::TensorOptions().dtype(at::kFloat)).to(like.scalar_type());
  std::vector<int64_t> shape(like.dim(), 1);
  shape[like.dim() - 3] = static_cast<int64_t>(v.size());
  return t.view(shape);
}

void check_channels(const LatentRange& r, const torch::Tensor& z) {
  if (z.dim() < 3 || z.size(z.dim() - 3) != r.channels()) {
    fail("latent has " + std::to_string(z.dim() >= 3 ? z.size(z.dim() - 3) : 0) + " channels, the field's range has " +
         std::to_string(r.channels()));
  }
}

}  // namespace

torch::Tensor LatentRange::normalize(const torch::Tensor& z) const {
  check_channels(*this, z);
  auto lo = channel_view(min, z), hi = channel_view(max, z);
  auto span = (hi - lo).clamp_min(1e-12);
  return (z - lo) / span;
}

torch::Tensor LatentRange::denormalize(const torch::Tensor& zn) const {
  check_channels(*this, zn);
  auto lo = channel_view(min, zn), hi = channel_view(max, zn);
  return zn.clamp(0, 1) * (hi - lo) + lo;
}

nlohmann::json LatentRange::to_json() const { return {{"min", min}, {"max", max}}; }

LatentRange LatentRange::from_json(const nlohmann::json& j, const std::string& path) {
  LatentRange r;
  try {
    r.min = j.at("min").get<std::vector<float>>();
    r.max = j.at("max").get<std::vector<float>>();
  } catch (const nlohmann::json::exception& e) {
    fail(path, std::string("bad latent range: ") + e.what());
  }
  if (r.min.empty() || r.min.size() != r.max.size()) fail(path, "latent range min/max sizes differ or are empty");
  for (size_t c = 0; c < r.min.size(); ++c) {
    if (!std::isfinite(r.min[c]) || !std::isfinite(r.max[c]) || r.max[c] < r.min[c]) {
      fail(path, "latent range of channel " + std::to_string(c) + " is not a finite interval");
    }
  }
  return r;
}

LatentRange compute_latent_range(const std::vector<torch::Tensor>& latents) {
  if (latents.empty()) fail("no training latents to normalise");
  const int64_t C = latents[0].size(0);
  auto lo = at::full({C}, std::numeric_limits<float>::infinity());
  auto hi = at::full({C}, -std::numeric_limits<float>::infinity());
  for (const auto& z : latents) {
    if (z.dim() != 3 || z.size(0) != C) fail("training latents have different channel counts");
    auto flat = z.detach().to(at::kFloat).reshape({C, -1});
    lo = at::minimum(lo, std::get<0>(flat.min(1)));
    hi = at::maximum(hi, std::get<0>(flat.max(1)));
  }
  if (!at::isfinite(lo).all().item<bool>() || !at::isfinite(hi).all().item<bool>()) {
    fail("training latents contain NaN or infinite values");
  }
  LatentRange r;
  r.min.assign(lo.data_ptr<float>(), lo.data_ptr<float>() + C);
  r.max.assign(hi.data_ptr<float>(), hi.data_ptr<float>() + C);
  return r;
}

}  // namespace lrf
