#pragma once
// Runs tests/reference/ae_reference.py with Debian's python3 + torch, writing fixtures into a temporary
// or build folder (never into the repository).
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include "lrf/core/atomic_file.h"
#include "lrf/core/safetensors.h"

namespace lrf_test {

inline const char* kPython = "/usr/bin/python3";

// A new empty folder under the system temp dir, unique to this process and `name`.
inline std::filesystem::path fresh_dir(const std::string& name) {
  auto dir = std::filesystem::temp_directory_path() / ("lrf_test_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// Runs the reference script with `args`; fails the test with a clear message if python3-torch is
// missing (scripts/install-deps.sh installs it) or the script fails.
inline ::testing::AssertionResult run_reference(const std::string& args) {
  std::string probe = std::string(kPython) + " -c 'import torch, numpy' > /dev/null 2>&1";
  if (std::system(probe.c_str()) != 0) {
    return ::testing::AssertionFailure() << kPython << " with torch and numpy is required for the PyTorch "
                                         << "comparison (apt-get install python3-torch python3-numpy, see "
                                         << "scripts/install-deps.sh)";
  }
  std::string cmd = std::string(kPython) + " " + LRF_SOURCE_DIR + "/tests/reference/ae_reference.py " + args;
  int rc = std::system(cmd.c_str());
  if (rc != 0) return ::testing::AssertionFailure() << "reference script failed (" << rc << "): " << cmd;
  return ::testing::AssertionSuccess();
}

// Fixtures that depend only on the reference script and its arguments are generated once per build
// folder and reused by later test processes (ctest runs every test in its own process): the folder
// <build>/test_fixtures/<name>-<hash of script + args>. Generation writes into a private folder that is
// then renamed into place, so concurrent tests (ctest -j) never see a half-written fixture. Returns
// an empty path (after a test failure) if generation fails.
inline std::filesystem::path cached_fixture(const std::string& name, const std::string& args) {
  namespace fs = std::filesystem;
  std::string script;
  {
    std::ifstream in(std::string(LRF_SOURCE_DIR) + "/tests/reference/ae_reference.py", std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    script = ss.str();
  }
  std::ostringstream key;
  key << name << "-" << std::hex << std::hash<std::string>{}(script + "\n" + args);
  fs::path root = fs::path(LRF_BINARY).parent_path() / "test_fixtures";
  fs::path final_dir = root / key.str();
  if (fs::exists(final_dir / "done")) return final_dir;
  fs::create_directories(root);
  fs::path tmp = root / (key.str() + ".tmp" + std::to_string(::getpid()));
  fs::remove_all(tmp);
  fs::create_directories(tmp);
  auto ok = run_reference(args + " --out " + tmp.string());
  if (!ok) {
    ADD_FAILURE() << ok.message();
    fs::remove_all(tmp);
    return {};
  }
  std::ofstream(tmp / "done") << "ok\n";
  std::error_code ec;
  fs::rename(tmp, final_dir, ec);  // fails harmlessly if another process got there first
  if (ec) fs::remove_all(tmp);
  // Fixtures of earlier versions of the script are never used again: remove them.
  for (const auto& entry : fs::directory_iterator(root, ec)) {
    const std::string other = entry.path().filename().string();
    if (entry.is_directory() && other.rfind(name + "-", 0) == 0 && other.find(".tmp") == std::string::npos &&
        entry.path() != final_dir) {
      fs::remove_all(entry.path(), ec);
    }
  }
  return final_dir;
}

inline std::string shared_dir() { return LRF_SHARED_DIR; }

// Writes {"image": image} to a file named after its content under <build>/test_fixtures and returns its
// path: an input the reference script reads, whose PyTorch output cached_fixture can then cache.
inline std::string fixture_input(const std::string& name, const at::Tensor& image) {
  lrf::StateDict input;
  input.insert("image", image);
  const std::string bytes = lrf::serialize_safetensors(input);
  const std::filesystem::path path = std::filesystem::path(LRF_BINARY).parent_path() / "test_fixtures" /
                                     (name + "-input-" + std::to_string(std::hash<std::string>{}(bytes)) + ".safetensors");
  std::filesystem::create_directories(path.parent_path());
  if (!std::filesystem::exists(path)) lrf::write_file_atomic(path.string(), bytes);
  return path.string();
}

}  // namespace lrf_test
