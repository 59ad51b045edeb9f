#include "lrf/core/train_log.h"

#include <fstream>
#include <sstream>
#include <utility>

#include "lrf/core/atomic_file.h"

namespace lrf {

TrainLog::TrainLog(std::string path, std::string header, int elapsed_column)
    : path_(std::move(path)), header_(std::move(header)), elapsed_column_(elapsed_column) {}

double TrainLog::resume(int64_t step) {
  rows_.clear();
  double elapsed = 0;
  std::ifstream in(path_);
  std::string line;
  if (!std::getline(in, line)) return 0;  // the header
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    std::istringstream fields(line);
    std::string field;
    std::getline(fields, field, ',');
    int64_t row_step = 0;
    try {
      row_step = std::stoll(field);
    } catch (const std::exception&) {
      break;  // a row cut short by a crash while the log was written elsewhere: the rows before it stand
    }
    if (row_step > step) break;
    for (int k = 1; k <= elapsed_column_ && std::getline(fields, field, ','); ++k) {
      if (k == elapsed_column_) {
        try {
          elapsed = std::stod(field);
        } catch (const std::exception&) {
        }
      }
    }
    rows_ += line + "\n";
  }
  return elapsed;
}

void TrainLog::add(const std::string& row) { rows_ += row + "\n"; }

void TrainLog::write() const { write_file_atomic(path_, header_ + "\n" + rows_); }

}  // namespace lrf
