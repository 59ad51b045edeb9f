#include "lrf/autoencoder/resolve.h"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>

#include "lrf/core/error.h"

namespace lrf {
namespace {

namespace fs = std::filesystem;

const char* const kExtensions[] = {".safetensors", ".pth", ".pt", ".ckpt", ".bin"};

bool is_weights_file(const fs::path& p) {
  std::error_code ec;
  if (!fs::is_regular_file(p, ec)) return false;
  for (const char* e : kExtensions)
    if (p.extension() == e) return true;
  return false;
}

fs::path executable_dir() {
  std::error_code ec;
  fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::path() : exe.parent_path();
}

// A folder: one *encoder* + one *decoder* file, or a single weights file with both halves.
bool resolve_folder(const fs::path& dir, AutoencoderFiles* out) {
  std::vector<fs::path> files, enc, dec;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    if (!is_weights_file(entry.path())) continue;
    files.push_back(entry.path());
    std::string name = entry.path().filename().string();
    std::transform(name.begin(), name.end(), name.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (name.find("encoder") != std::string::npos) enc.push_back(entry.path());
    if (name.find("decoder") != std::string::npos) dec.push_back(entry.path());
  }
  if (enc.size() == 1 && dec.size() == 1) {
    *out = {enc[0].string(), dec[0].string(), dir.string()};
    return true;
  }
  if (files.size() == 1) {
    *out = {files[0].string(), files[0].string(), dir.string()};
    return true;
  }
  if (!files.empty()) {
    fail(dir.string(), "ambiguous autoencoder folder: expected one *encoder* and one *decoder* weights file, "
                       "or a single weights file; found " + std::to_string(files.size()) + " files");
  }
  return false;
}

bool resolve_path(const fs::path& p, AutoencoderFiles* out) {
  std::error_code ec;
  if (fs::is_directory(p, ec)) return resolve_folder(p, out);
  if (is_weights_file(p)) {
    *out = {p.string(), p.string(), p.string()};
    return true;
  }
  return false;
}

}  // namespace

std::vector<std::string> model_search_dirs() {
  std::vector<std::string> dirs;
  if (const char* env = std::getenv("LRF_MODELS"); env && *env) dirs.push_back(env);
  dirs.push_back("models");
  dirs.push_back("../shared/models");
  fs::path exe = executable_dir();
  if (!exe.empty()) {
    dirs.push_back((exe.parent_path() / "models").string());
    dirs.push_back((exe.parent_path() / ".." / "shared" / "models").lexically_normal().string());
  }
  return dirs;
}

AutoencoderFiles resolve_autoencoder(const std::string& name_or_path) {
  if (name_or_path.empty()) fail("no autoencoder given (use a name such as taef2, or a path)");
  AutoencoderFiles files;
  std::error_code ec;
  if (fs::exists(name_or_path, ec)) {
    if (resolve_path(name_or_path, &files)) return files;
    fail(name_or_path, "not an autoencoder: expected a weights file (" + std::string(".safetensors, .pth, .ckpt") +
                           ") or a folder holding *encoder* and *decoder* weights");
  }
  const bool plain_name = name_or_path.find('/') == std::string::npos;
  std::string looked;
  if (plain_name) {
    for (const auto& dir : model_search_dirs()) {
      looked += (looked.empty() ? "" : ", ") + dir;
      fs::path base = fs::path(dir) / name_or_path;
      if (resolve_path(base, &files)) return files;
      for (const char* e : kExtensions) {
        if (resolve_path(fs::path(dir) / (name_or_path + e), &files)) return files;
      }
    }
  }
  fail(name_or_path, plain_name ? "autoencoder not found; looked in " + looked +
                                      " (set LRF_MODELS, or run scripts/fetch-models.sh)"
                                : "file or folder not found");
}

}  // namespace lrf
