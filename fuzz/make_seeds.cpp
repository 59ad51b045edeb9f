// Writes the seed corpus for every fuzz target from files the project itself produces: a synthetic
// scene's COLMAP model (text and binary), .npy arrays, a correspondence file, transforms.json, safetensors,
// a PyTorch zip checkpoint and its pickle (as torch.save lays them out), .ply fields and config.json of
// RGB and latent runs.
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <torch/torch.h>

#include "harness.h"
#include "lrf/align/correspondences.h"
#include "lrf/align/correspondences_io.h"
#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/core/run_info.h"
#include "lrf/core/safetensors.h"
#include "lrf/latent/latent_normalization.h"
#include "lrf/scene/colmap_model.h"
#include "lrf/scene/scene.h"
#include "lrf/scene/synthetic_scene.h"
#include "lrf/splat/run/run_folder.h"
#include "lrf/splat/gaussians.h"
#include "lrf/splat/ply_io.h"

namespace fs = std::filesystem;

namespace {

void seed(const fs::path& dir, const std::string& target, const std::string& name, const std::string& bytes) {
  fs::create_directories(dir / target);
  lrf::write_file_atomic((dir / target / name).string(), bytes);
}

std::string npy(const std::string& descr, const std::string& shape, size_t count, size_t item) {
  std::string header = "{'descr': '" + descr + "', 'fortran_order': False, 'shape': " + shape + ", }";
  while ((10 + header.size() + 1) % 64) header += ' ';
  header += '\n';
  std::string out = "\x93NUMPY\x01";
  out += '\0';
  out += static_cast<char>(header.size() & 0xff);
  out += static_cast<char>(header.size() >> 8);
  out += header;
  for (size_t i = 0; i < count * item; ++i) out += static_cast<char>(i * 7);
  return out;
}

// --- A writer of torch.save's zip layout (stored entries) and its protocol-2 pickle, as PyTorch writes
// them for a state dict: OrderedDict of _rebuild_tensor_v2(persistent storage, offset, size, stride, ...).

std::string le(std::uint64_t v, int bytes) {
  std::string out;
  for (int i = 0; i < bytes; ++i) out += static_cast<char>((v >> (8 * i)) & 0xff);
  return out;
}

std::uint32_t crc32(const std::string& data) {
  std::uint32_t c = 0xffffffffu;
  for (unsigned char b : data) {
    c ^= b;
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
  }
  return ~c;
}

std::string zip_stored(const std::vector<std::pair<std::string, std::string>>& entries) {
  std::string out, central;
  for (const auto& [name, data] : entries) {
    const std::uint64_t offset = out.size();
    const std::uint32_t crc = crc32(data);
    out += le(0x04034b50, 4) + le(20, 2) + le(0, 2) + le(0, 2) + le(0, 2) + le(0, 2) + le(crc, 4) +
           le(data.size(), 4) + le(data.size(), 4) + le(name.size(), 2) + le(0, 2) + name + data;
    central += le(0x02014b50, 4) + le(20, 2) + le(20, 2) + le(0, 2) + le(0, 2) + le(0, 2) + le(0, 2) + le(crc, 4) +
               le(data.size(), 4) + le(data.size(), 4) + le(name.size(), 2) + le(0, 2) + le(0, 2) + le(0, 2) +
               le(0, 2) + le(0, 4) + le(offset, 4) + name;
  }
  const std::uint64_t cd_offset = out.size();
  out += central;
  out += le(0x06054b50, 4) + le(0, 2) + le(0, 2) + le(entries.size(), 2) + le(entries.size(), 2) +
         le(central.size(), 4) + le(cd_offset, 4) + le(0, 2);
  return out;
}

struct PickledTensor {
  std::string name, storage_type, key;
  std::int64_t storage_numel, offset;
  std::vector<std::int64_t> size, stride;
};

std::string pickle_string(const std::string& s) { return "X" + le(s.size(), 4) + s; }
std::string pickle_int(std::int64_t v) {
  if (v >= 0 && v < 256) return "K" + std::string(1, static_cast<char>(v));
  return "J" + le(static_cast<std::uint64_t>(v), 4);
}
std::string pickle_int_tuple(const std::vector<std::int64_t>& v) {
  std::string out = "(";
  for (auto x : v) out += pickle_int(x);
  return out + "t";
}

std::string pickle_state_dict(const std::vector<PickledTensor>& tensors) {
  std::string p = "\x80\x02";
  p += "ccollections\nOrderedDict\n)R(";
  for (const auto& t : tensors) {
    p += pickle_string(t.name);
    p += "ctorch._utils\n_rebuild_tensor_v2\n";
    p += "((" + pickle_string("storage") + "ctorch\n" + t.storage_type.substr(6) + "\n" + pickle_string(t.key) +
         pickle_string("cpu") + pickle_int(t.storage_numel) + "tQ";
    p += pickle_int(t.offset) + pickle_int_tuple(t.size) + pickle_int_tuple(t.stride) + "\x89";
    p += "ccollections\nOrderedDict\n)RtR";
  }
  p += "u.";
  return p;
}

std::string bytes_of(const at::Tensor& t) {
  at::Tensor c = t.contiguous();
  return std::string(static_cast<const char*>(c.data_ptr()), static_cast<size_t>(c.nbytes()));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s CORPUS_DIR\n", argv[0]);
    return 2;
  }
  try {
    fs::path out(argv[1]);
    fs::path scene = out / "_scene";
    fs::remove_all(scene);
    lrf::write_synthetic_scene(scene.string(), {4, "40x32", 0, 60});  // lrf loads views of 32 px a side or more
    fs::path sparse = scene / "sparse" / "0";
    lrf::ColmapModel model = lrf::read_colmap_model(sparse.string());
    // A model with a distorted camera too, so that the intrinsics path sees several models.
    model.cameras[2] = {2, "OPENCV", 40, 32, {30, 31, 20, 16, 0.01, -0.02, 0.001, 0.002}};
    lrf::write_colmap_binary(sparse.string(), model);
    lrf::write_colmap_text(sparse.string(), model);
    const char* stems[] = {"cameras", "images", "points3D"};
    for (int k = 0; k < 3; ++k) {
      std::string prefix(1, static_cast<char>(k));
      seed(out, "colmap_bin", std::string(stems[k]) + ".bin", prefix + lrf::read_file((sparse / (std::string(stems[k]) + ".bin")).string()));
      seed(out, "colmap_txt", std::string(stems[k]) + ".txt", prefix + lrf::read_file((sparse / (std::string(stems[k]) + ".txt")).string()));
    }
    seed(out, "npy", "poses_3x17.npy", npy("<f8", "(3, 17)", 51, 8));
    seed(out, "npy", "f4_2x2.npy", npy("<f4", "(2, 2)", 4, 4));
    lrf::Scene s = lrf::load_scene(scene.string());
    lrf::CorrespondenceSet set = lrf::correspondences_from_tracks(s, 3);
    set.pairs.resize(std::min<size_t>(set.pairs.size(), 2));
    for (auto& p : set.pairs) {
      p.xi.resize(std::min<size_t>(p.xi.size(), 4));
      p.xj.resize(p.xi.size());
    }
    lrf::write_correspondences((out / "_tmp.corr").string(), set);
    seed(out, "correspondences", "tracks.corr", lrf::read_file((out / "_tmp.corr").string()));
    fs::remove(out / "_tmp.corr");

    // transforms.json: NeRF synthetic (camera_angle_x, paths without extension) and nerfstudio (per-file
    // intrinsics, distortion) from the synthetic scene's cameras.
    {
      nlohmann::json synthetic = {{"camera_angle_x", 0.69}, {"frames", nlohmann::json::array()}};
      nlohmann::json studio = {{"fl_x", 30.0}, {"fl_y", 31.0}, {"cx", 20.0}, {"cy", 16.0}, {"w", 40}, {"h", 32},
                               {"k1", 0.01}, {"k2", -0.02}, {"p1", 0.001}, {"p2", 0.0},
                               {"camera_model", "OPENCV"}, {"frames", nlohmann::json::array()}};
      int i = 0;
      for (const auto& v : s.views) {
        if (i++ == 2) break;
        Eigen::Matrix4d c2w = v.camera.camera_to_world();
        c2w.col(1) *= -1;  // OpenCV -> OpenGL camera axes
        c2w.col(2) *= -1;
        nlohmann::json m = nlohmann::json::array();
        for (int r = 0; r < 4; ++r) m.push_back({c2w(r, 0), c2w(r, 1), c2w(r, 2), c2w(r, 3)});
        synthetic["frames"].push_back({{"file_path", "./train/r_" + std::to_string(i)}, {"transform_matrix", m}});
        studio["frames"].push_back({{"file_path", "images/" + v.name}, {"transform_matrix", m}});
      }
      studio["frames"][0]["fl_x"] = 29.5;  // a per-frame value overriding the file's
      seed(out, "transforms", "synthetic.json", synthetic.dump(1));
      seed(out, "transforms", "nerfstudio.json", studio.dump(1));
      studio["camera_model"] = "OPENCV_FISHEYE";
      seed(out, "transforms", "fisheye.json", studio.dump());
    }

    // Tensors: safetensors of several dtypes with metadata, and the same as a torch.save zip checkpoint.
    {
      torch::manual_seed(0);
      lrf::StateDict sd;
      sd.insert("conv.weight", torch::randn({2, 3}));
      sd.insert("conv.bias", torch::randn({3}).to(torch::kHalf));
      sd.insert("norm.weight", torch::randn({2}).to(torch::kBFloat16));
      sd.insert("steps", torch::arange(2, torch::kLong));
      sd.insert("mask", torch::tensor({true, false}));
      seed(out, "safetensors", "dtypes.safetensors", lrf::serialize_safetensors(sd, {{"format", "pt"}}));
      lrf::StateDict one;
      one.insert("w", torch::ones({1}));
      seed(out, "safetensors", "one.safetensors", lrf::serialize_safetensors(one));

      // data/0: a float storage shared by a [2, 3] tensor and a strided view of it; data/1: a half one.
      at::Tensor f = torch::arange(6, torch::kFloat);
      at::Tensor h = torch::arange(3, torch::kFloat).to(torch::kHalf);
      std::vector<PickledTensor> tensors = {
          {"conv.weight", "torch.FloatStorage", "0", 6, 0, {2, 3}, {3, 1}},
          {"conv.weight_t", "torch.FloatStorage", "0", 6, 1, {2, 2}, {1, 3}},
          {"conv.bias", "torch.HalfStorage", "1", 3, 0, {3}, {1}},
          {"scalar", "torch.HalfStorage", "1", 3, 2, {}, {}},
      };
      std::string pkl = pickle_state_dict(tensors);
      seed(out, "pickle", "state_dict.pkl", pkl);
      static const char evil[] = "\x80\x02" "cos\nsystem\n" "X\x02\x00\x00\x00ls" "\x85R.";
      seed(out, "pickle", "evil_os_system.pkl", std::string(evil, sizeof evil - 1));
      seed(out, "torch_zip", "state_dict.pth",
           zip_stored({{"archive/data.pkl", pkl}, {"archive/byteorder", "little"}, {"archive/data/0", bytes_of(f)},
                       {"archive/data/1", bytes_of(h)}, {"archive/version", "3\n"}}));
    }

    // .ply fields: RGB at SH degree 1 and a 4-channel latent field at degree 0.
    for (auto [channels, degree] : {std::pair<int, int>{3, 1}, {4, 0}}) {
      torch::manual_seed(1);
      auto g = lrf::splat::gaussians_from_points(torch::randn({3, 3}), torch::rand({3, channels}), degree);
      const std::string tmp = (out / "_tmp.ply").string();
      lrf::splat::write_ply(tmp, g);
      seed(out, "ply", "c" + std::to_string(channels) + "_sh" + std::to_string(degree) + ".ply", lrf::read_file(tmp));
      fs::remove(tmp);
    }

    // config.json of an RGB run and of a latent run, with the keys lrf train writes.
    {
      lrf::SceneOptions so;
      nlohmann::json rgb = lrf::run_record({{"scene", scene.string()}, {"iters", 300}, {"seed", 0}});
      rgb.update(lrf::splat::scene_config(scene.string(), so, s, (out / "run").string()));
      rgb["space"] = "rgb";
      rgb["sh_degree"] = 3;
      rgb["mip"] = false;
      rgb["background"] = {0.0f, 0.0f, 0.0f};
      rgb["extent"] = 1.5;
      rgb["result"] = {{"steps", 300}, {"gaussians", 1000}, {"seconds", 2.5}, {"final_loss", 0.05}};
      seed(out, "field_config", "rgb.json", rgb.dump(2));
      nlohmann::json latent = rgb;
      lrf::LatentRange range;
      range.min = {-1.5f, -2.0f, 0.0f, -0.25f};
      range.max = {1.5f, 2.5f, 1.0f, 0.75f};
      latent["space"] = "latent";
      latent["sh_degree"] = 0;
      latent["crop_to_multiple_of_8"] = true;
      latent["background"] = std::vector<float>(4, 0.0f);
      latent["autoencoder"] = "taef2";
      latent["encoder"] = "";
      latent["autoencoder_identity"] = "taef2:0123456789abcdef";
      latent["latent_channels"] = 4;
      latent["latent_range"] = range.to_json();
      latent["init"] = "latents";
      seed(out, "field_config", "latent.json", latent.dump(2));
      nlohmann::json feature = latent;  // a feature field (feature-gs): 2 features lifted to the 4 channels
      feature["feature_dim"] = 2;
      feature["background"] = std::vector<float>(2, 0.0f);
      seed(out, "field_config", "feature.json", feature.dump(2));
    }
    // Scene arguments of lrf pipeline, as the docs write them.
    seed(out, "scene_spec", "plain.txt", "../shared/scenes/llff-fern");
    seed(out, "scene_spec", "images.txt", "../shared/scenes/llff-fern:--images=images_8");
    seed(out, "scene_spec", "downscale.txt", "scenes/llff-room:--downscale=2");
    seed(out, "scene_spec", "both.txt", "/data/a:b/nerd-maryrose:--images=images_masked:--downscale=3");
    fs::remove_all(scene);
    for (const auto& t : lrf::fuzz::target_names()) {
      if (!fs::exists(out / t)) throw lrf::Error("no seeds for fuzz target " + t);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
