#include "lrf/core/cache_key.h"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "lrf/core/error.h"

namespace fs = std::filesystem;

namespace lrf {

std::string default_cache_dir() {
  if (const char* c = std::getenv("LRF_CACHE"); c && *c) return c;
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return (fs::path(x) / "lrf").string();
  if (const char* h = std::getenv("HOME"); h && *h) return (fs::path(h) / ".cache" / "lrf").string();
  return ".lrf-cache";
}

uint64_t fnv1a64(const std::string& s) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

std::string hash_hex(const std::string& text) {
  char name[17];
  std::snprintf(name, sizeof name, "%016llx", static_cast<unsigned long long>(fnv1a64(text)));
  return name;
}

std::string file_stamp(const std::string& path) {
  std::error_code ec;
  auto size = fs::file_size(path, ec);
  auto time = fs::last_write_time(path, ec).time_since_epoch().count();
  std::ostringstream s;
  s << fs::absolute(path).lexically_normal().string() << ":" << (ec ? 0 : size) << ":" << (ec ? 0 : time);
  return s.str();
}

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

}  // namespace lrf
