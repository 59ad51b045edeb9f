#include "lrf/eval/npy_state_dict.h"

#include <filesystem>

#include "lrf/core/error.h"

namespace lrf {

torch::Tensor npy_to_tensor(const NpyArray& array) {
  auto data = const_cast<double*>(array.data.data());  // from_blob wants a mutable pointer; we only read
  return torch::from_blob(data, array.shape, torch::kFloat64).to(torch::kFloat32);  // to() copies
}

TensorMap read_npy_state_dict(const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) fail(dir, "state dict folder not found");
  TensorMap dict;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const fs::path& p = entry.path();
    if (p.extension() != ".npy" || !entry.is_regular_file()) continue;
    dict[p.stem().string()] = npy_to_tensor(read_npy(p.string()));
  }
  if (ec) fail(dir, "cannot list folder: " + ec.message());
  if (dict.empty()) fail(dir, "no .npy files in the state dict folder");
  return dict;
}

}  // namespace lrf
