#include "lrf/core/resources.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include "lrf/core/error.h"

namespace lrf {
namespace {

// Reads a "Name:   1234 kB" line of /proc/self/status, in kB; -1 if absent (not Linux, or no procfs).
long status_kb(const std::string& name) {
  std::ifstream in("/proc/self/status");
  std::string line;
  const std::string key = name + ":";
  while (std::getline(in, line)) {
    if (line.compare(0, key.size(), key) != 0) continue;
    std::istringstream fields(line.substr(key.size()));
    long kb = -1;
    fields >> kb;
    return kb;
  }
  return -1;
}

double kb_to_mb(long kb) { return kb < 0 ? 0.0 : static_cast<double>(kb) / 1024.0; }

}  // namespace

double peak_memory_mb() { return kb_to_mb(status_kb("VmHWM")); }

double current_memory_mb() { return kb_to_mb(status_kb("VmRSS")); }

bool reset_peak_memory() {
  // Writing "5" to clear_refs resets the peak RSS (Linux >= 4.0, see proc(5)).
  std::ofstream out("/proc/self/clear_refs");
  if (!out) return false;
  out << "5";
  out.flush();
  return static_cast<bool>(out);
}

double directory_size_mb(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  auto status = fs::symlink_status(path, ec);
  if (ec || !fs::exists(status)) fail(path, "cannot measure size: not found");
  uintmax_t bytes = 0;
  if (fs::is_regular_file(status)) {
    bytes = fs::file_size(path, ec);
    if (ec) fail(path, "cannot measure size: " + ec.message());
  } else if (fs::is_directory(status)) {
    for (auto it = fs::recursive_directory_iterator(path, ec); !ec && it != fs::recursive_directory_iterator();
         it.increment(ec)) {
      std::error_code file_ec;
      if (it->is_symlink(file_ec) || !it->is_regular_file(file_ec)) continue;
      uintmax_t size = it->file_size(file_ec);
      if (!file_ec) bytes += size;  // a file removed while we walk is not an error
    }
    if (ec) fail(path, "cannot measure size: " + ec.message());
  }
  return static_cast<double>(bytes) / (1024.0 * 1024.0);
}

}  // namespace lrf
