#pragma once
// Runs tests/reference/ae_reference.py with Debian's python3 + torch, writing fixtures into a fresh
// temporary folder (never into the repository).
#include <cstdlib>
#include <filesystem>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

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

inline std::string shared_dir() { return LRF_SHARED_DIR; }

}  // namespace lrf_test
