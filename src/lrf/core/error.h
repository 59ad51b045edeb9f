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

// Throws Error(path, what): for the common "this file is bad because ..." case.
[[noreturn]] void fail(const std::string& path, const std::string& what);
[[noreturn]] void fail(const std::string& what);

}  // namespace lrf
