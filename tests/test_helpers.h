#pragma once
// Shared helpers for the tests: where the shared data is, temporary folders, running the CLI.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "lrf/core/error.h"
#include "lrf/core/precision.h"
#include "lrf/scene/synthetic_scene.h"

namespace lrf::test {

inline std::string shared_dir() {
  const char* env = std::getenv("LRF_SHARED");
  return env ? env : LRF_SHARED_DIR;
}

inline std::string scene_dir(const std::string& name) { return shared_dir() + "/scenes/" + name; }

// Sets an environment variable for one scope (child processes inherit it).
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old, had_ = true;
    ::setenv(name, value, 1);
  }
  ~ScopedEnv() { had_ ? ::setenv(name_, old_.c_str(), 1) : ::unsetenv(name_); }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  const char* name_;
  std::string old_;
  bool had_ = false;
};

// A fresh, empty folder under the system temp dir, removed by the destructor.
class TempDir {
 public:
  explicit TempDir(const std::string& name) {
    path_ = std::filesystem::temp_directory_path() / ("lrf_test_" + name + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() { std::filesystem::remove_all(path_); }
  std::string str() const { return path_.string(); }
  std::string operator/(const std::string& p) const { return (path_ / p).string(); }

 private:
  std::filesystem::path path_;
};

struct CommandResult {
  int exit_code;
  std::string output;  // stdout and stderr together
};

// Runs the built `lrf` binary with the given arguments (shell-quoted by the caller).
inline CommandResult run_lrf(const std::string& args) {
  std::string cmd = std::string(LRF_BINARY) + " " + args + " 2>&1";
  CommandResult r{0, ""};
  FILE* p = ::popen(cmd.c_str(), "r");
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.output.append(buf, n);
  int status = ::pclose(p);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

// A small synthetic scene, written once and shared by the test processes (ctest runs each test in its
// own process, in parallel): written to a private folder and renamed into place, so readers never see
// a partial scene.
inline std::string synthetic_scene(const SyntheticOptions& o = {8, "64x48", 3, 800}) {
  namespace fs = std::filesystem;
  // Under the build folder, so that a rebuilt project does not reuse another build's scenes.
  std::string dir = (fs::path(LRF_BINARY).parent_path() / "test_data" / ("synth_" + std::to_string(o.views) + "_" + o.size + "_" +
                                                   std::to_string(o.seed) + "_" + std::to_string(o.points)))
                        .string();
  if (!fs::exists(dir)) {
    fs::create_directories(fs::path(dir).parent_path());
    std::string tmp = dir + ".tmp" + std::to_string(::getpid());
    fs::remove_all(tmp);
    write_synthetic_scene(tmp, o);
    std::error_code ec;
    fs::rename(tmp, dir, ec);
    if (ec) fs::remove_all(tmp);
  }
  return dir;
}

// The message of the lrf::Error that `f` throws, or "" when it throws none.
inline std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const lrf::Error& e) {
    return e.what();
  }
  return "";
}

// Sets the precision that load_autoencoder gives its models (default_precision) for one scope.
class ScopedPrecision {
 public:
  explicit ScopedPrecision(Precision p) : before_(default_precision()) { set_default_precision(p); }
  ~ScopedPrecision() { set_default_precision(before_); }
  ScopedPrecision(const ScopedPrecision&) = delete;
  ScopedPrecision& operator=(const ScopedPrecision&) = delete;

 private:
  Precision before_;
};

// Test-name suffix for tests parametrised by precision ("fp32", "bf16").
inline std::string precision_param_name(const ::testing::TestParamInfo<Precision>& info) {
  return precision_name(info.param);
}

// The header line of a run's train_log.csv ("" when the file cannot be read).
inline std::string logged_header(const std::string& log) {
  std::ifstream in(log);
  std::string header;
  std::getline(in, header);
  return header;
}

// Column `column` (0 = step) of a run's train_log.csv, one value per logged row. A row without that
// column, or a cell that is not a number, throws an error naming the file, row and column.
inline std::vector<double> logged_column(const std::string& log, int column) {
  std::ifstream in(log);
  if (!in) throw std::runtime_error(log + ": cannot be read");
  std::string line;
  std::getline(in, line);  // the header
  std::vector<double> values;
  for (int row = 1; std::getline(in, line); ++row) {
    if (line.empty()) continue;
    size_t start = 0;
    for (int k = 0; k < column && start != std::string::npos; ++k) {
      start = line.find(',', start);
      if (start != std::string::npos) ++start;
    }
    const std::string cell = start == std::string::npos ? "" : line.substr(start, line.find(',', start) - start);
    size_t used = 0;
    double value = 0;
    try {
      value = std::stod(cell, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0) {
      throw std::runtime_error(log + ": row " + std::to_string(row) + " has no number in column " +
                               std::to_string(column) + ": '" + line + "'");
    }
    values.push_back(value);
  }
  return values;
}

// The column named `name` in the CSV's header; an error naming the file when there is none.
inline std::vector<double> logged_column(const std::string& log, const std::string& name) {
  std::istringstream header(logged_header(log));
  std::string cell;
  for (int column = 0; std::getline(header, cell, ','); ++column)
    if (cell == name) return logged_column(log, column);
  throw std::runtime_error(log + ": no column '" + name + "' in its header");
}

}  // namespace lrf::test
