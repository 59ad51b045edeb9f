// Fuzz targets for the formats that yield tensors (linked with libtorch): safetensors, the PyTorch zip
// checkpoint, its pickle on its own, .ply fields and a run's config.json.
#include <stdexcept>
#include <unordered_set>

#include <nlohmann/json.hpp>
#include <torch/torch.h>

#include "harness.h"
#include "lrf/core/error.h"
#include "lrf/core/pickle.h"
#include "lrf/core/safetensors.h"
#include "lrf/core/torch_zip.h"
#include "lrf/latent/latent_config.h"
#include "lrf/splat/run/field_kind.h"
#include "lrf/splat/run/run_config.h"
#include "lrf/splat/ply_io.h"

namespace lrf::fuzz {
namespace {

// What a consumer does with a loaded tensor: read every element (small ones; the readers bound sizes).
void touch(const at::Tensor& t) {
  if (!t.defined()) throw std::logic_error("reader returned an undefined tensor");
  if (t.numel() <= (1 << 16)) (void)t.to(at::kDouble).sum().item<double>();
}

void touch(const StateDict& d) {
  for (const auto& item : d) touch(item.value());
}

// The persistent loader of torch_zip.cpp without an archive: a storage of the claimed size (bounded).
pickle::Ref fake_storage(const pickle::Value& pid) {
  using K = pickle::Value::Kind;
  if (pid.kind != K::tuple || pid.items.size() != 5 || pid.items[1]->kind != K::global ||
      pid.items[4]->kind != K::integer || pid.items[4]->integer < 0 || pid.items[4]->integer > 4096) {
    throw Error("fuzz", "unsupported persistent id");
  }
  at::ScalarType type;
  std::size_t element_size = 0;
  if (!pickle::storage_dtype(pid.items[1]->text, &type, &element_size)) throw Error("fuzz", "bad storage type");
  auto v = std::make_shared<pickle::Value>();
  v->kind = K::tensor;
  v->tensor = torch::zeros({pid.items[4]->integer}, torch::TensorOptions().dtype(type));
  return v;
}

// Every value once (the memo can share a value between containers, so the tree is a DAG).
void touch(const pickle::Value& v, std::unordered_set<const pickle::Value*>* seen) {
  if (!seen->insert(&v).second) return;
  if (v.kind == pickle::Value::Kind::tensor) touch(v.tensor);
  for (const auto& i : v.items) touch(*i, seen);
  for (const auto& [k, x] : v.entries) {
    touch(*k, seen);
    touch(*x, seen);
  }
}

void field_config(const std::string& bytes) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(bytes);
  } catch (const nlohmann::json::exception&) {
    return;  // read_json_file's refusal
  }
  // Each reader on its own: a refusal by one must not hide the others.
  try {
    field_kind_of_config(j, "fuzz");
  } catch (const Error&) {
  }
  try {
    splat::parse_field_config(j, "fuzz");
  } catch (const Error&) {
  }
  auto l = parse_latent_config(j, "fuzz");
  // A latent field renders its latent channels, a feature field (feature-gs) its features.
  const int rendered = l.feature_dim > 0 ? l.feature_dim : l.range.channels();
  if (static_cast<int>(l.field.background.size()) != rendered)
    throw std::logic_error("latent config accepted with mismatched channels");
}

}  // namespace

const std::vector<std::string>& tensor_target_names() {
  static const std::vector<std::string> names = {"safetensors", "torch_zip", "pickle", "ply", "field_config"};
  return names;
}

bool run_tensor_target(const std::string& target, const std::string& bytes) {
  if (target == "safetensors") {
    touch(parse_safetensors(bytes, "fuzz"));
  } else if (target == "torch_zip") {
    touch(parse_torch_state_dict(bytes, "fuzz"));
  } else if (target == "pickle") {
    std::unordered_set<const pickle::Value*> seen;
    touch(*pickle::unpickle(bytes, "fuzz", fake_storage), &seen);
  } else if (target == "ply") {
    splat::Gaussians g = splat::parse_ply(bytes, "fuzz");
    try {
      g.check("fuzz");
    } catch (const Error& e) {
      throw std::logic_error(std::string("parse_ply returned an inconsistent field: ") + e.what());
    }
    touch(g.means);
    touch(g.sh);
  } else if (target == "field_config") {
    field_config(bytes);
  } else {
    return false;
  }
  return true;
}

}  // namespace lrf::fuzz
