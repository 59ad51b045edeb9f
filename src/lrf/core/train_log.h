#pragma once
// A CSV that a training run grows row by row (train_log.csv, a curve of scores), kept in memory and written
// whole and atomically: with each checkpoint, or at once for rows worth watching as they come. A resumed
// run keeps the rows up to its checkpoint's step (the first column) and drops those past it, which the
// run makes again.
#include <cstdint>
#include <string>

namespace lrf {

class TrainLog {
 public:
  // `header` without its newline; `elapsed_column`: the 0-based column holding the elapsed seconds that a
  // resumed run continues (-1: none).
  TrainLog(std::string path, std::string header, int elapsed_column = -1);
  // Reads back the file's rows up to `step` (none when there is no file) and returns the elapsed seconds of
  // the last of them (0 without such a row or column).
  double resume(int64_t step);
  // One row, without its newline.
  void add(const std::string& row);
  void write() const;

 private:
  std::string path_, header_, rows_;
  int elapsed_column_;
};

}  // namespace lrf
