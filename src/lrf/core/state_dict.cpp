#include "lrf/core/state_dict.h"

#include <filesystem>
#include <fstream>

#include "lrf/core/error.h"
#include "lrf/core/safetensors.h"
#include "lrf/core/torch_zip.h"
#include "lrf/core/zip_reader.h"

namespace lrf {

StateDict load_state_dict(const std::string& path) {
  std::ifstream probe(path, std::ios::binary);
  if (!probe) fail(path, "file not found or unreadable");
  unsigned char magic[2] = {0, 0};
  probe.read(reinterpret_cast<char*>(magic), 2);
  probe.close();
  if (looks_like_zip(path)) return read_torch_state_dict(path);
  if (looks_like_safetensors(path)) return read_safetensors(path);
  if (magic[0] == 0x80) {
    fail(path, "legacy (pre-1.6, non-zip) PyTorch checkpoint: re-save it with a recent torch.save");
  }
  if (std::filesystem::path(path).extension() == ".safetensors") return read_safetensors(path);  // says what is wrong
  fail(path, "not a weights file: neither a PyTorch zip checkpoint nor safetensors");
}

}  // namespace lrf
