#pragma once
// A COLMAP database (SQLite) opened for the few queries lrf makes of it: errors name the file.
#include <functional>
#include <string>

struct sqlite3;
struct sqlite3_stmt;

namespace lrf {

class ColmapDatabase {
 public:
  // Opens `path` read-only or for writing; throws lrf::Error naming it when it cannot.
  ColmapDatabase(const std::string& path, bool writable);
  ~ColmapDatabase();
  ColmapDatabase(const ColmapDatabase&) = delete;
  ColmapDatabase& operator=(const ColmapDatabase&) = delete;

  // Runs statements that return nothing (one or several, ';'-separated).
  void exec(const std::string& sql);
  // Runs a query and calls `row` for each of its rows (read with sqlite3_column_*).
  void each_row(const std::string& sql, const std::function<void(sqlite3_stmt*)>& row);

 private:
  std::string path_;
  sqlite3* db_ = nullptr;
};

}  // namespace lrf
