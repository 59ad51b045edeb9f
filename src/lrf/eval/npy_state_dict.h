#pragma once
// A state dict stored as a folder of NumPy files, one `<key>.npy` per tensor (float32 or float64). It is
// the simplest format that a Python script can write with numpy alone; the tests use it to bring
// PyTorch-made weights into C++. Real weight files (.pth, .safetensors) have their own loader.
#include <string>

#include "lrf/core/npy.h"
#include "lrf/eval/lpips.h"

namespace lrf {

// A float32 tensor with the array's shape (a copy).
torch::Tensor npy_to_tensor(const NpyArray& array);
// Every *.npy file in `dir`, keyed by its name without the extension; throws lrf::Error naming the
// folder if it is missing or holds no .npy file, or naming the file if one is unreadable.
TensorMap read_npy_state_dict(const std::string& dir);

}  // namespace lrf
