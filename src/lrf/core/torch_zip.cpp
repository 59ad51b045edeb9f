#include "lrf/core/torch_zip.h"

#include <map>
#include <utility>
#include <vector>

#include <torch/torch.h>

#include "lrf/core/error.h"
#include "lrf/core/zip_reader.h"

namespace lrf {
namespace {

pickle::Ref read_archive(ZipReader& zip) {
  const std::string& path = zip.path();
  // The archive's single root folder is named after the file at save time: find it via data.pkl.
  const ZipReader::Entry* pkl = nullptr;
  for (const auto& e : zip.entries()) {
    auto slash = e.name.find('/');
    if (slash != std::string::npos && e.name.substr(slash) == "/data.pkl") {
      if (pkl) fail(path, "zip archive holds more than one data.pkl");
      pkl = &e;
    }
  }
  if (!pkl) fail(path, "zip archive without <root>/data.pkl: not a PyTorch checkpoint");
  const std::string root = pkl->name.substr(0, pkl->name.find('/'));
  if (const auto* order = zip.find(root + "/byteorder")) {
    if (zip.read(*order) != "little") fail(path, "big-endian checkpoints are not supported");
  }
  // data.pkl of a real state dict is a few MB; refuse absurd sizes before reading them.
  if (pkl->size > (512u << 20)) fail(path, "data.pkl of " + std::to_string(pkl->size) + " bytes is too large");
  std::string bytes = zip.read(*pkl);

  // Storages are shared between views (e.g. tied weights): load each key once.
  std::map<std::string, at::Tensor> storages;
  auto persistent_load = [&](const pickle::Value& pid) -> pickle::Ref {
    using K = pickle::Value::Kind;
    if (pid.kind != K::tuple || pid.items.size() != 5 || pid.items[0]->kind != K::string ||
        pid.items[0]->text != "storage" || pid.items[1]->kind != K::global || pid.items[2]->kind != K::string ||
        pid.items[4]->kind != K::integer || pid.items[4]->integer < 0) {
      fail(path, "unsupported persistent id in data.pkl (expected ('storage', type, key, location, numel))");
    }
    at::ScalarType type;
    std::size_t element_size = 0;
    if (!pickle::storage_dtype(pid.items[1]->text, &type, &element_size)) {
      fail(path, "unsupported storage type " + pid.items[1]->text);
    }
    const std::string& key = pid.items[2]->text;
    auto value = std::make_shared<pickle::Value>();
    value->kind = K::tensor;
    auto it = storages.find(key);
    if (it != storages.end()) {
      if (it->second.scalar_type() != type) fail(path, "storage " + key + " used with two dtypes");
      value->tensor = it->second;
      return value;
    }
    const auto* entry = zip.find(root + "/data/" + key);
    if (!entry) fail(path, "storage '" + key + "' is missing from the archive");
    const auto numel = static_cast<std::uint64_t>(pid.items[4]->integer);
    // The entry's real size bounds the allocation, whatever numel the pickle claims.
    if (numel > entry->size / element_size || numel * element_size != entry->size) {
      fail(path, "storage '" + key + "' claims " + std::to_string(numel) + " elements but holds " +
                     std::to_string(entry->size) + " bytes");
    }
    at::Tensor t = torch::empty({static_cast<std::int64_t>(numel)}, torch::TensorOptions().dtype(type));
    zip.read(*entry, t.data_ptr());
    storages.emplace(key, t);
    value->tensor = t;
    return value;
  };
  return pickle::unpickle(bytes, path + ":" + pkl->name, persistent_load);
}

using Kind = pickle::Value::Kind;

// Whether a dict holds a weight: a tensor entry of at least one dimension (a training checkpoint's
// `loss` or `step` is a scalar tensor, not a weight).
bool holds_weights(const pickle::Value& dict) {
  for (const auto& [k, v] : dict.entries)
    if (k->kind == Kind::string && v->kind == Kind::tensor && v->tensor.dim() > 0) return true;
  return false;
}

// The dict that holds the weights: the root when it holds any, else the one nested dict that does (a
// training checkpoint's "state_dict", "model", ...); where several do, the first of kPreferred.
const pickle::Value& weights_dict(const pickle::Value& root, const std::string& path) {
  static const char* const kPreferred[] = {"state_dict", "model_state_dict", "model", "module", "net"};
  std::vector<std::pair<std::string, const pickle::Value*>> nested;
  for (const auto& [k, v] : root.entries)
    if (k->kind == Kind::string && v->kind == Kind::dict && holds_weights(*v)) nested.emplace_back(k->text, v.get());
  for (const char* name : kPreferred)
    for (const auto& [key, dict] : nested)
      if (key == name) return *dict;
  if (holds_weights(root)) return root;
  if (nested.size() == 1) return *nested[0].second;
  std::string names, scalars;
  for (const auto& [key, dict] : nested) names += (names.empty() ? "" : ", ") + key;
  if (!nested.empty()) fail(path, "checkpoint holds several dicts of weights (" + names + "): which is the model's is unclear");
  for (const auto& [k, v] : root.entries)
    if (k->kind == Kind::string && v->kind == Kind::tensor) scalars += (scalars.empty() ? "" : ", ") + k->text;
  fail(path, scalars.empty() ? "checkpoint holds no tensors"
                             : "checkpoint holds no weights, only scalar tensors (" + scalars + ")");
}

StateDict state_dict_of(const pickle::Ref& root, const std::string& path) {
  if (root->kind != Kind::dict) fail(path, "checkpoint does not hold a dict of tensors");
  const pickle::Value& dict = weights_dict(*root, path);
  StateDict out;
  for (const auto& [k, v] : dict.entries) {
    if (k->kind != Kind::string || v->kind != Kind::tensor) continue;
    if (out.contains(k->text)) fail(path, "duplicate tensor name " + k->text);
    out.insert(k->text, v->tensor);
  }
  return out;
}

}  // namespace

pickle::Ref read_torch_zip(const std::string& path) {
  ZipReader zip(path);
  return read_archive(zip);
}

StateDict read_torch_state_dict(const std::string& path) { return state_dict_of(read_torch_zip(path), path); }

pickle::Ref parse_torch_zip(const std::string& bytes, const std::string& name) {
  ZipReader zip(std::make_unique<MemorySource>(bytes, name));
  return read_archive(zip);
}

StateDict parse_torch_state_dict(const std::string& bytes, const std::string& name) {
  return state_dict_of(parse_torch_zip(bytes, name), name);
}

}  // namespace lrf
