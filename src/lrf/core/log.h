#pragma once
// Logging for the CLI and long jobs. Messages go to stderr so that stdout stays clean for results
// (JSON, tables). Verbosity: quiet (warnings and errors only), normal, or JSON lines for machines.
#include <string>

namespace lrf {

enum class LogMode { normal, quiet, json };

void set_log_mode(LogMode mode);
LogMode log_mode();

void log_info(const std::string& message);
void log_warn(const std::string& message);
void log_error(const std::string& message);

}  // namespace lrf
