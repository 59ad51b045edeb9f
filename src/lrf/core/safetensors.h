#pragma once
// The safetensors format: 8-byte little-endian header length N, N bytes of JSON
// {"name": {"dtype": "F32", "shape": [..], "data_offsets": [begin, end]}, "__metadata__": {...}},
// then the raw little-endian tensor bytes. Supported dtypes: F32, F16, BF16, I64 (and F64, I32, U8,
// BOOL, which cost nothing extra). A file is untrusted: every length and offset is checked against the
// file size before anything is allocated.
#include <map>
#include <string>

#include "lrf/core/state_dict.h"

namespace lrf {

// Reads every tensor; tensors are contiguous CPU tensors of the stored dtype.
StateDict read_safetensors(const std::string& path);
// Same, from bytes already in memory (`name` is used in error messages).
StateDict parse_safetensors(const std::string& bytes, const std::string& name);
// The "__metadata__" string map of a file (empty if none).
std::map<std::string, std::string> read_safetensors_metadata(const std::string& path);

// Serialises tensors (made contiguous, on CPU) in the given order, with optional string metadata.
std::string serialize_safetensors(const StateDict& tensors,
                                  const std::map<std::string, std::string>& metadata = {});
// Writes atomically.
void write_safetensors(const std::string& path, const StateDict& tensors,
                       const std::map<std::string, std::string>& metadata = {});

// True if the file starts like a safetensors file (plausible header length followed by '{').
bool looks_like_safetensors(const std::string& path);

}  // namespace lrf
