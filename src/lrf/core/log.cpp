#include "lrf/core/log.h"

#include <atomic>
#include <cstdio>
#include <mutex>

#include <nlohmann/json.hpp>

namespace lrf {
namespace {
std::atomic<LogMode> g_mode{LogMode::normal};
std::mutex g_mutex;

void emit(const char* level, const std::string& message) {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (g_mode == LogMode::json) {
    nlohmann::json line = {{"level", level}, {"message", message}};
    std::fprintf(stderr, "%s\n", line.dump().c_str());
  } else if (std::string(level) == "info") {
    std::fprintf(stderr, "%s\n", message.c_str());
  } else {
    std::fprintf(stderr, "%s: %s\n", level, message.c_str());
  }
  std::fflush(stderr);
}
}  // namespace

void set_log_mode(LogMode mode) { g_mode = mode; }
LogMode log_mode() { return g_mode; }

void log_info(const std::string& message) {
  if (g_mode != LogMode::quiet) emit("info", message);
}
void log_warn(const std::string& message) { emit("warning", message); }
void log_error(const std::string& message) { emit("error", message); }

}  // namespace lrf
