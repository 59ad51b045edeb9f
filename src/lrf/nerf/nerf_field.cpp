#include "lrf/nerf/nerf_field.h"

#include <cmath>

#include <ATen/ATen.h>
#include <ATen/CPUGeneratorImpl.h>

#include "lrf/core/error.h"
#include "lrf/core/safetensors.h"

namespace lrf::nerf {
namespace {

int json_int(const nlohmann::json& j, const char* key, const std::string& path, int lo, int hi) {
  const auto& v = j.at(key);
  if (!v.is_number_integer() || v.get<int64_t>() < lo || v.get<int64_t>() > hi)
    fail(path, std::string("NeRF spec: \"") + key + "\" must be an integer in " + std::to_string(lo) + ".." +
                   std::to_string(hi));
  return v.get<int>();
}

}  // namespace

void NerfSpec::check() const {
  grid.check();
  auto bad = [](const std::string& what) { fail("NeRF: " + what); };
  if (hidden < 1 || hidden > 1024) bad("hidden width must be 1..1024");
  if (geo_features < 0 || geo_features > 256) bad("geometry features must be 0..256");
  if (channels < 1 || channels > 1024) bad("channels must be 1..1024");
  if (coarse_samples < 2 || coarse_samples > 1024) bad("coarse samples per ray must be 2..1024");
  if (fine_samples < 0 || fine_samples > 1024) bad("fine samples per ray must be 0..1024");
  if (static_cast<int>(background.size()) != channels) bad("the background needs one value per channel");
}

nlohmann::json NerfSpec::to_json() const {
  return {{"grid",
           {{"levels", grid.levels},
            {"features", grid.features},
            {"log2_table", grid.log2_table},
            {"base_resolution", grid.base_resolution},
            {"max_resolution", grid.max_resolution}}},
          {"hidden", hidden},
          {"geo_features", geo_features},
          {"channels", channels},
          {"coarse_samples", coarse_samples},
          {"fine_samples", fine_samples},
          {"bounds", bounds.to_json()},
          {"background", background}};
}

NerfSpec NerfSpec::from_json(const nlohmann::json& j, const std::string& path) {
  NerfSpec s;
  if (!j.is_object()) fail(path, "NeRF spec is not a JSON object");
  try {
    const auto& g = j.at("grid");
    s.grid.levels = json_int(g, "levels", path, 1, 32);
    s.grid.features = json_int(g, "features", path, 1, 8);
    s.grid.log2_table = json_int(g, "log2_table", path, 4, 24);
    s.grid.base_resolution = json_int(g, "base_resolution", path, 1, 4096);
    s.grid.max_resolution = json_int(g, "max_resolution", path, 1, 1 << 16);
    s.hidden = json_int(j, "hidden", path, 1, 1024);
    s.geo_features = json_int(j, "geo_features", path, 0, 256);
    s.channels = json_int(j, "channels", path, 1, 1024);
    s.coarse_samples = json_int(j, "coarse_samples", path, 2, 1024);
    s.fine_samples = json_int(j, "fine_samples", path, 0, 1024);
    s.bounds = SceneBounds::from_json(j.at("bounds"), path);
    s.background = j.at("background").get<std::vector<float>>();
  } catch (const nlohmann::json::exception& e) {
    fail(path, std::string("missing or bad NeRF spec: ") + e.what());
  }
  for (float b : s.background)
    if (!std::isfinite(b)) fail(path, "NeRF spec: the background holds a value that is not finite");
  try {
    s.check();
  } catch (const Error& e) {
    fail(path, e.what());
  }
  return s;
}

NerfField NerfField::create(const NerfSpec& spec, uint64_t seed) {
  spec.check();
  NerfField f;
  f.spec = spec;
  auto gen = at::make_generator<at::CPUGeneratorImpl>(seed);
  f.table = at::empty({spec.grid.total_entries(), spec.grid.features}, at::kFloat).uniform_(-1e-4, 1e-4, gen);
  f.density = Mlp::create({spec.grid.output_dim(), spec.hidden, 1 + spec.geo_features}, seed + 1);
  f.latent = Mlp::create({1 + spec.geo_features, spec.hidden, spec.hidden, spec.channels}, seed + 2);
  return f;
}

NerfField NerfField::zeros_like() const {
  NerfField z;
  z.spec = spec;
  z.table = at::zeros_like(table);
  z.density = density.zeros_like();
  z.latent = latent.zeros_like();
  return z;
}

int64_t NerfField::parameter_count() const {
  return table.numel() + density.parameter_count() + latent.parameter_count();
}

std::vector<std::pair<std::string, at::Tensor>> NerfField::named_tensors() const {
  std::vector<std::pair<std::string, at::Tensor>> t = {{"grid.table", table}};
  for (const auto& [name, mlp] : {std::pair<const char*, const Mlp*>{"density", &density}, {"latent", &latent}}) {
    for (int k = 0; k < mlp->layers(); ++k) {
      t.emplace_back(std::string(name) + "." + std::to_string(k) + ".weight", mlp->weights[static_cast<size_t>(k)]);
      t.emplace_back(std::string(name) + "." + std::to_string(k) + ".bias", mlp->biases[static_cast<size_t>(k)]);
    }
  }
  return t;
}

void NerfField::save(const std::string& path, const std::map<std::string, std::string>& metadata) const {
  StateDict tensors;
  for (const auto& [name, t] : named_tensors()) tensors.insert(name, t.contiguous());
  auto meta = metadata;
  meta["format"] = "lrf latent-nerf field";
  meta["spec"] = spec.to_json().dump();
  write_safetensors(path, tensors, meta);
}

NerfField NerfField::load(const std::string& path) {
  const auto meta = read_safetensors_metadata(path);
  if (!meta.count("spec")) fail(path, "not a latent-nerf field: its metadata has no \"spec\"");
  nlohmann::json spec_json;
  try {
    spec_json = nlohmann::json::parse(meta.at("spec"));
  } catch (const nlohmann::json::exception& e) {
    fail(path, std::string("the NeRF spec in the metadata is not JSON: ") + e.what());
  }
  // A template of the expected layout; every tensor of the file must match it.
  NerfField f = NerfField::create(NerfSpec::from_json(spec_json, path), 0);
  const StateDict stored = read_safetensors(path);
  for (auto& [name, expected] : f.named_tensors()) {
    const at::Tensor* t = stored.find(name);
    if (!t) fail(path, "missing tensor \"" + name + "\"");
    if (t->scalar_type() != at::kFloat) fail(path, "tensor \"" + name + "\" is not float32");
    if (t->sizes() != expected.sizes())
      fail(path, "tensor \"" + name + "\" has shape " + std::string(c10::str(t->sizes())) + ", the spec needs " +
                     std::string(c10::str(expected.sizes())));
    if (!at::isfinite(*t).all().item<bool>()) fail(path, "tensor \"" + name + "\" holds values that are not finite");
    expected.copy_(*t);  // `expected` shares storage with the field's own tensor
  }
  if (static_cast<int64_t>(stored.size()) != static_cast<int64_t>(f.named_tensors().size()))
    fail(path, "holds tensors that a latent-nerf field of this spec does not have");
  return f;
}

}  // namespace lrf::nerf
