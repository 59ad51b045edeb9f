#include "lrf/scene/colmap_database.h"

#include <sqlite3.h>

#include "lrf/core/error.h"

namespace lrf {

ColmapDatabase::ColmapDatabase(const std::string& path, bool writable) : path_(path) {
  if (sqlite3_open_v2(path.c_str(), &db_, writable ? SQLITE_OPEN_READWRITE : SQLITE_OPEN_READONLY, nullptr) !=
      SQLITE_OK) {
    const std::string message = db_ ? sqlite3_errmsg(db_) : "cannot open";
    sqlite3_close(db_);
    db_ = nullptr;
    fail(path, "cannot open the COLMAP database: " + message);
  }
}

ColmapDatabase::~ColmapDatabase() { sqlite3_close(db_); }

void ColmapDatabase::exec(const std::string& sql) {
  char* error = nullptr;
  if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &error) != SQLITE_OK) {
    const std::string message = error ? error : "unknown error";
    sqlite3_free(error);
    fail(path_, "cannot update the COLMAP database: " + message);
  }
}

void ColmapDatabase::each_row(const std::string& sql, const std::function<void(sqlite3_stmt*)>& row) {
  sqlite3_stmt* st = nullptr;
  if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &st, nullptr) != SQLITE_OK)
    fail(path_, std::string("not a COLMAP database (") + sqlite3_errmsg(db_) + ")");
  while (sqlite3_step(st) == SQLITE_ROW) row(st);
  sqlite3_finalize(st);
}

}  // namespace lrf
