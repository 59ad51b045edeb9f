#pragma once
// A state dict: parameter name -> tensor, in file order. Shared by every weights reader and writer.
#include <string>

#include <torch/ordered_dict.h>
#include <ATen/Tensor.h>

namespace lrf {

using StateDict = torch::OrderedDict<std::string, at::Tensor>;

// Reads a checkpoint of any supported format, chosen by content (not by extension):
//  - safetensors (.safetensors),
//  - PyTorch's zip format (.pth, .pt, .ckpt, .bin): a state dict (OrderedDict / dict of tensors), or a
//    training checkpoint holding one under "state_dict", "model", ... (Lightning / ldm checkpoints, a
//    torch.save of {model, optimizer, loss}); non-tensor entries such as "global_step" are skipped, and
//    a file holding no weight at all (only scalars such as a loss) is an error.
// Throws lrf::Error naming the file for anything unreadable or unsafe.
StateDict load_state_dict(const std::string& path);

}  // namespace lrf
