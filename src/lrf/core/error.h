#pragma once
// One error type for everything a user can get wrong: it names the file and what is wrong with it, and
// the CLI turns it into a one-line message and a non-zero exit code.
#include <stdexcept>
#include <string>

namespace lrf {

class Error : public std::runtime_error {
 public:
  Error(const std::string& path, const std::string& what);
  explicit Error(const std::string& what);
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

// A command line that asks for something lrf refuses before doing any work: an option's value out of its
// range, options that do not go together. The CLI exits with 2 for it, as for a command line it cannot
// parse, and with 1 for every other Error (bad input data, missing files).
class UsageError : public Error {
 public:
  explicit UsageError(const std::string& what) : Error(what) {}
};

// Throws Error(path, what): for the common "this file is bad because ..." case.
[[noreturn]] void fail(const std::string& path, const std::string& what);
[[noreturn]] void fail(const std::string& what);
// Throws UsageError(what); `what` names the option, e.g. "--scale must be a positive number".
[[noreturn]] void fail_usage(const std::string& what);

}  // namespace lrf
