#include "lrf/core/run_info.h"

#include <ctime>
#include <map>
#include <utility>

#include <opencv2/core/version.hpp>
#include <torch/version.h>

#include "lrf/build_info.h"
#include "lrf/core/atomic_file.h"
#include "lrf/core/cpu_features.h"
#include "lrf/core/error.h"
#include "lrf/core/openmp_wait.h"
#include "lrf/core/precision.h"
#include "lrf/core/threads.h"

namespace lrf {
namespace {
std::vector<std::string> g_command;
}

void set_command_line(int argc, char** argv) {
  g_command.assign(argv, argv + argc);
}

const std::vector<std::string>& command_line() { return g_command; }

namespace {
std::map<std::string, std::function<nlohmann::json()>>& version_facts() {
  static std::map<std::string, std::function<nlohmann::json()>> facts;  // filled before main() runs
  return facts;
}
}  // namespace

void add_version_fact(const std::string& key, std::function<nlohmann::json()> fact) {
  version_facts()[key] = std::move(fact);
}

nlohmann::json version_info() {
  nlohmann::json info = {{"lrf", LRF_VERSION},
          {"git", LRF_GIT_COMMIT},
          {"build", LRF_BUILD_TYPE},
          {"libtorch", TORCH_VERSION},
          {"opencv", CV_VERSION},
          {"threads", thread_count()},
          // How idle OpenMP workers waited (lrf's long commands run with "passive"; see openmp_wait.h).
          {"openmp_wait_policy", openmp_wait_policy()},
          // What the autoencoders computed in (fp32 or bf16: outputs differ by bf16 rounding), what was
          // asked for (fp32, bf16 or auto), and whether the CPU has native bf16 (what auto decides on).
          {"autoencoder_precision", precision_name(resolve_precision(default_precision()))},
          {"autoencoder_precision_requested", precision_name(default_precision())},
          {"cpu_bf16", cpu_has_bf16()},
          // Whether bf16 inference and training ran their 3x3 convolutions as Winograd's (roundings
          // differ from the direct convolution's).
          {"autoencoder_winograd", resolve_precision(default_precision()) == Precision::bf16 && winograd_enabled()},
          // Its output tiles (2 or 3; they round differently).
          {"autoencoder_winograd_tile", winograd_tile()},
          // The widest vectors lrf's own kernels used ($LRF_CPU_ISA caps them), and whether float32 ran its
          // 3x3 convolutions as Winograd's F(4x4) or F(2x2) (sums in another order than the direct
          // convolution's: outputs differ by float32 rounding, ~1e-6 of the values).
          {"simd_level", simd_level_name(simd_level())},
          {"autoencoder_winograd_f32",
           resolve_precision(default_precision()) == Precision::fp32 && winograd_f32_enabled()},
          {"autoencoder_winograd_f32_tile", winograd_f32_tile()}};
  for (const auto& [key, fact] : version_facts()) info[key] = fact();
  return info;
}

std::string version_string() {
  return std::string("lrf ") + LRF_VERSION + " (git " + LRF_GIT_COMMIT + ", " + LRF_BUILD_TYPE +
         ", libtorch " + TORCH_VERSION + ", OpenCV " + CV_VERSION + ")";
}

nlohmann::json run_record(const nlohmann::json& options) {
  std::time_t now = std::time(nullptr);
  char buf[64];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  return {{"command", g_command}, {"versions", version_info()}, {"time", buf}, {"options", options}};
}

void write_json_file(const std::string& path, const nlohmann::json& value) {
  write_file_atomic(path, value.dump(2) + "\n");
}

nlohmann::json read_json_file(const std::string& path) {
  std::string text = read_file(path);
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    fail(path, std::string("invalid JSON: ") + e.what());
  }
}

std::string differing_settings(const nlohmann::json& recorded, const nlohmann::json& wanted) {
  std::string differ;
  for (const auto& [key, value] : wanted.items()) {
    if (!recorded.contains(key) || recorded[key] != value) {
      differ += " " + key + " (" + (recorded.contains(key) ? recorded[key].dump() : "none") + " vs " + value.dump() + ")";
    }
  }
  return differ;
}

}  // namespace lrf
