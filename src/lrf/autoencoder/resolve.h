#pragma once
// Finding an autoencoder's weight files from a name or a path.
#include <string>
#include <vector>

namespace lrf {

struct AutoencoderFiles {
  std::string encoder;  // weights of the encoder half (may be the same file as `decoder`)
  std::string decoder;
  std::string source;   // the folder or file that was resolved, for messages
};

// The folders searched for a model name, in order: $LRF_MODELS, ./models, ../shared/models (relative
// to the current directory), then models and ../shared/models relative to the executable's folder's
// parent. Folders that do not exist are included (they are reported in "not found" errors).
std::vector<std::string> model_search_dirs();

// `name_or_path` is
//  - a weights file (.safetensors/.pth/.pt/.ckpt/.bin) holding both halves (a KL-VAE, diffusers
//    AutoencoderTiny single file), or
//  - a folder holding exactly one file whose name contains "encoder" and one with "decoder" (the
//    TAESD layout: taef2_encoder.pth, taef2_decoder.pth), or exactly one weights file, or
//  - a name: <dir>/<name>/ (as above) or <dir>/<name>.<ext> in the search folders.
// Throws lrf::Error listing where it looked.
AutoencoderFiles resolve_autoencoder(const std::string& name_or_path);

}  // namespace lrf
