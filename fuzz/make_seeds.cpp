// Writes the seed corpus for every fuzz target from files the project itself produces: a synthetic
// scene's COLMAP model (text and binary), .npy arrays, and a correspondence file.
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "harness.h"
#include "lrf/align/correspondences.h"
#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/scene/colmap_model.h"
#include "lrf/scene/scene.h"
#include "lrf/scene/synthetic_scene.h"

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
    lrf::write_synthetic_scene(scene.string(), {4, "32x24", 0, 60});
    fs::path sparse = scene / "sparse" / "0";
    lrf::ColmapModel model = lrf::read_colmap_model(sparse.string());
    // A model with a distorted camera too, so that the intrinsics path sees several models.
    model.cameras[2] = {2, "OPENCV", 32, 24, {30, 31, 16, 12, 0.01, -0.02, 0.001, 0.002}};
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
