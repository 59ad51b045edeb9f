#include "lrf/scene/step_records.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include "lrf/core/atomic_file.h"

namespace fs = std::filesystem;

namespace lrf {

StepRecords::StepRecords(std::string dir, bool start_over) : dir_(std::move(dir)), rerun_(start_over) {}

std::string StepRecords::path(const std::string& step) const { return (fs::path(dir_) / (step + ".done")).string(); }

bool StepRecords::skip(const std::string& step, const std::string& settings, bool output_present) {
  chain_ += "[" + step + "]\n" + settings + "\n";
  if (!rerun_ && output_present) {
    std::ifstream in(path(step));
    std::stringstream recorded;
    recorded << in.rdbuf();
    if (in && recorded.str() == chain_) return true;
  }
  rerun_ = true;
  std::error_code ec;
  fs::remove(path(step), ec);
  return false;
}

void StepRecords::finished(const std::string& step) { write_file_atomic(path(step), chain_); }

}  // namespace lrf
