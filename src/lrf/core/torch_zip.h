#pragma once
// PyTorch's zip checkpoint format (torch.save since 1.6; .pth / .pt / .ckpt): an archive
// `<root>/data.pkl` (the pickled object), `<root>/data/<key>` (raw little-endian storages),
// `<root>/byteorder`. Read with the restricted unpickler of pickle.h: nothing in the file is executed.
#include <string>

#include "lrf/core/pickle.h"
#include "lrf/core/state_dict.h"

namespace lrf {

// The unpickled root object, tensors resolved against the archive's storages.
pickle::Ref read_torch_zip(const std::string& path);
// The state dict in a checkpoint: the root dict, or a dict nested in a training checkpoint ("state_dict",
// "model", ...: the one that holds weights); entries whose values are not tensors are skipped. Throws
// lrf::Error when no dict holds a weight (a tensor of at least one dimension), naming what it found.
StateDict read_torch_state_dict(const std::string& path);
// Same as the two above, from the archive's bytes already in memory (`name` is used in error messages).
pickle::Ref parse_torch_zip(const std::string& bytes, const std::string& name);
StateDict parse_torch_state_dict(const std::string& bytes, const std::string& name);

}  // namespace lrf
