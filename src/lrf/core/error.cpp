#include "lrf/core/error.h"

namespace lrf {

Error::Error(const std::string& path, const std::string& what)
    : std::runtime_error(path.empty() ? what : path + ": " + what), path_(path) {}

Error::Error(const std::string& what) : std::runtime_error(what) {}

void fail(const std::string& path, const std::string& what) { throw Error(path, what); }
void fail(const std::string& what) { throw Error(what); }
void fail_usage(const std::string& what) { throw UsageError(what); }

}  // namespace lrf
