#include "lrf/latent/latent_cache.h"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include <ATen/ATen.h>
#include <torch/torch.h>

#include "lrf/autoencoder/image_tensor.h"
#include "lrf/autoencoder/resolve.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/progress.h"
#include "lrf/core/safetensors.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {

// FNV-1a: a stable 64-bit hash across builds and runs (std::hash promises neither).
uint64_t fnv1a(const std::string& s) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

std::string file_stamp(const std::string& path) {
  std::error_code ec;
  auto size = fs::file_size(path, ec);
  auto time = fs::last_write_time(path, ec).time_since_epoch().count();
  std::ostringstream s;
  s << fs::absolute(path).lexically_normal().string() << ":" << (ec ? 0 : size) << ":" << (ec ? 0 : time);
  return s.str();
}

// Weights are named by their content, not their path or time: a copy or a fresh download of the same
// file keeps every run and cache made with it valid, and an edited file of the same size does not.
std::string content_stamp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot read the weights file");
  uint64_t h = 1469598103934665603ull;
  uint64_t size = 0;
  std::vector<char> block(1 << 16);
  while (in) {
    in.read(block.data(), static_cast<std::streamsize>(block.size()));
    const auto n = static_cast<size_t>(in.gcount());
    for (size_t i = 0; i < n; ++i) {
      h ^= static_cast<unsigned char>(block[i]);
      h *= 1099511628211ull;
    }
    size += n;
  }
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  return fs::path(path).filename().string() + ":" + std::to_string(size) + ":" + hex;
}

}  // namespace

std::string default_cache_dir() {
  if (const char* c = std::getenv("LRF_CACHE"); c && *c) return c;
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return (fs::path(x) / "lrf").string();
  if (const char* h = std::getenv("HOME"); h && *h) return (fs::path(h) / ".cache" / "lrf").string();
  return ".lrf-cache";
}

std::string autoencoder_identity(const std::string& name_or_path, const std::string& encoder_override) {
  AutoencoderFiles files = resolve_autoencoder(name_or_path);
  std::string id = "encoder=" + content_stamp(files.encoder) + ";decoder=" + content_stamp(files.decoder);
  if (!encoder_override.empty()) id += ";encoder_override=" + content_stamp(encoder_override);
  return id;
}

std::string weights_file_identity(const std::string& path) { return content_stamp(path); }

LatentCacheResult encode_views_cached(const Scene& scene, const std::vector<int>& indices, Autoencoder& ae,
                                      const std::string& ae_identity, const std::string& cache_dir) {
  std::ostringstream key;
  key << "lrf-latents-v1;scene=" << fs::absolute(scene.root).lexically_normal().string() << ";ae=" << ae_identity;
  for (int i : indices) {
    const View& v = scene.views.at(static_cast<size_t>(i));
    if (v.camera.width % 8 || v.camera.height % 8) {
      fail(v.image_path, "view is " + std::to_string(v.camera.width) + "x" + std::to_string(v.camera.height) +
                             ": latent work needs sizes that are multiples of 8 (crop the scene)");
    }
    key << ";" << v.name << "@" << file_stamp(v.image_path) << "@" << v.camera.width << "x" << v.camera.height
        << "+" << v.crop_x << "," << v.crop_y << "/" << v.resize_width << "x" << v.resize_height;
  }
  LatentCacheResult result;
  char name[32];
  std::snprintf(name, sizeof name, "%016llx.safetensors", static_cast<unsigned long long>(fnv1a(key.str())));
  if (!cache_dir.empty()) result.path = (fs::path(cache_dir) / "latents" / name).string();

  if (!result.path.empty() && fs::exists(result.path)) {
    try {
      auto meta = read_safetensors_metadata(result.path);
      if (meta["key"] == key.str()) {
        StateDict all = read_safetensors(result.path);
        for (int i : indices) {
          const std::string& n = scene.views[static_cast<size_t>(i)].name;
          if (!all.contains(n)) fail(result.path, "no latent for view " + n);
          auto z = all[n].to(at::kFloat).contiguous();
          const auto& cam = scene.views[static_cast<size_t>(i)].camera;
          if (z.dim() != 3 || z.size(0) != ae.latent_channels() || z.size(1) != cam.height / 8 || z.size(2) != cam.width / 8)
            fail(result.path, "latent of view " + n + " has the wrong shape");
          if (!at::isfinite(z).all().item<bool>()) fail(result.path, "latent of view " + n + " is not finite");
          result.latents.push_back(z);
        }
        result.hit = true;
        return result;
      }
      log_warn(result.path + ": cache key differs (hash collision or edited file); re-encoding");
    } catch (const std::exception& e) {
      log_warn(std::string("latent cache unreadable, re-encoding: ") + e.what());
    }
    result.latents.clear();
  }

  torch::NoGradGuard no_grad;
  Progress progress("encode", static_cast<long>(indices.size()));
  StateDict out;
  long done = 0;
  for (int i : indices) {
    auto z = ae.encode(image_to_batch(scene.load_image(i))).squeeze(0).to(at::kFloat).contiguous();
    if (!at::isfinite(z).all().item<bool>()) fail(scene.views[static_cast<size_t>(i)].image_path, "encoder produced NaN/Inf");
    result.latents.push_back(z);
    out.insert(scene.views[static_cast<size_t>(i)].name, z);
    progress.update(++done);
  }
  if (!result.path.empty()) {
    fs::create_directories(fs::path(result.path).parent_path());
    write_safetensors(result.path, out, {{"key", key.str()}});
  }
  return result;
}

}  // namespace lrf
