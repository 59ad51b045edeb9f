#pragma once
// A restricted unpickler for PyTorch checkpoints (data.pkl inside torch.save's zip, protocols 2-4).
// Checkpoints are untrusted: only the globals a state dict needs are accepted (an allow-list in the
// spirit of torch.load(weights_only=True)); any other global (os.system, builtins.eval, ...) is refused
// with an error naming it as soon as it is read, and nothing is ever called or imported. Allowed:
//   collections.OrderedDict, torch._utils._rebuild_tensor_v2, torch._utils._rebuild_parameter,
//   torch.{Float,Half,BFloat16,Long,Double,Int,Byte,Bool}Storage (type tags for persistent ids).
// Every length read from the stream is bounded by the bytes that remain.
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <ATen/Tensor.h>

namespace lrf::pickle {

struct Value;
using Ref = std::shared_ptr<Value>;

struct Value {
  enum class Kind { none, boolean, integer, floating, string, bytes, tuple, list, dict, global, tensor };
  Kind kind = Kind::none;
  bool boolean = false;
  std::int64_t integer = 0;
  double floating = 0;
  std::string text;                          // string, bytes, or "module.name" of a global
  std::vector<Ref> items;                    // tuple, list
  std::vector<std::pair<Ref, Ref>> entries;  // dict (insertion order)
  at::Tensor tensor;                         // tensor, or a 1-D storage returned by the persistent loader
  int depth = 0;                             // container nesting below this value (bounded)
};

// Resolves a persistent id (the tuple after BINPERSID) to a value, typically a storage tensor.
using PersistentLoader = std::function<Ref(const Value& pid)>;

// Parses `bytes` (`name` is used in error messages, e.g. "model.ckpt:archive/data.pkl").
Ref unpickle(const std::string& bytes, const std::string& name, const PersistentLoader& persistent_load);

// Element size in bytes and dtype of a storage global such as "torch.HalfStorage"; false if unknown.
bool storage_dtype(const std::string& global, at::ScalarType* type, std::size_t* element_size);

}  // namespace lrf::pickle
