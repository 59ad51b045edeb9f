#include "lrf/latent/latent_cache.h"

#include <filesystem>
#include <sstream>

#include <ATen/ATen.h>
#include <torch/torch.h>

#include "lrf/autoencoder/image_tensor.h"
#include "lrf/autoencoder/resolve.h"
#include "lrf/core/cache_key.h"
#include "lrf/core/cpu_features.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/progress.h"
#include "lrf/core/safetensors.h"

namespace fs = std::filesystem;

namespace lrf {
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
  // v2: images are undistorted with a Lanczos kernel at the file's resolution (v1: bilinearly, after the resize).
  key << "lrf-latents-v2;scene=" << fs::absolute(scene.root).lexically_normal().string() << ";ae=" << ae_identity
      << ";precision=" << precision_name(ae.precision());  // bf16 encodes differ from fp32 ones by rounding
  // ... and bf16 ones through Winograd's convolution from those through the direct one.
  if (ae.precision() == Precision::bf16 && winograd_enabled()) {
    // (its tiles round differently: F(2x2, 3x3) was the only one before the key named the tile)
    const int tile = winograd_tile();
    key << ";convolution=winograd-f" << tile << "x" << tile << "-3x3";
  }
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
  if (!cache_dir.empty()) result.path = (fs::path(cache_dir) / "latents" / (hash_hex(key.str()) + ".safetensors")).string();

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
