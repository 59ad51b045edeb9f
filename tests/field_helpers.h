#pragma once
// Small trained fields shared by the tests of what reads fields (videos, the viewer, exports): trained
// once per build folder from the synthetic scene and renamed into place, so that test processes running
// in parallel never see a half-written field.
#include <filesystem>
#include <string>

#include <unistd.h>

#include "test_helpers.h"

namespace lrf::test {

// "rgb" (SH degree 1, 200 steps) or "latent" (TAEF2, 60 steps) on the 8-view 64x48 synthetic scene.
inline std::string tiny_field(const std::string& space) {
  namespace fs = std::filesystem;
  const std::string dir = (fs::path(LRF_BINARY).parent_path() / "test_data" / ("tiny_field_" + space)).string();
  if (fs::exists(fs::path(dir) / "point_cloud.ply")) return dir;
  const std::string scene = synthetic_scene({8, "64x48", 3, 800});
  const std::string tmp = dir + ".tmp" + std::to_string(::getpid());
  fs::remove_all(tmp);
  const std::string args = space == "rgb"
                               ? " --space rgb --iters 200 --sh-degree 1"
                               : " --space latent --autoencoder taef2 --iters 60 --cache-dir '" + tmp + ".cache'";
  auto r = run_lrf("--threads 2 -q train '" + scene + "'" + args + " -o '" + tmp + "'");
  fs::remove_all(tmp + ".cache");
  if (r.exit_code != 0) {
    fs::remove_all(tmp);
    throw std::runtime_error("training the tiny " + space + " field failed:\n" + r.output);
  }
  std::error_code ec;
  fs::rename(tmp, dir, ec);
  if (ec) fs::remove_all(tmp);  // another test process got there first
  return dir;
}

}  // namespace lrf::test
