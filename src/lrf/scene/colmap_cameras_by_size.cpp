#include "lrf/scene/colmap_cameras_by_size.h"

#include <sqlite3.h>

#include <map>
#include <utility>
#include <vector>

#include "lrf/core/error.h"

namespace lrf {
namespace {

class Connection {
 public:
  explicit Connection(const std::string& path) : path_(path) {
    if (sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READWRITE, nullptr) != SQLITE_OK) {
      const std::string message = db_ ? sqlite3_errmsg(db_) : "cannot open";
      sqlite3_close(db_);
      db_ = nullptr;
      fail(path, "cannot open the COLMAP database: " + message);
    }
  }
  ~Connection() { sqlite3_close(db_); }
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  void exec(const std::string& sql) {
    char* error = nullptr;
    if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &error) != SQLITE_OK) {
      const std::string message = error ? error : "unknown error";
      sqlite3_free(error);
      fail(path_, "cannot update the COLMAP database: " + message);
    }
  }

  // (camera_id, width, height) of every camera, in id order.
  std::vector<std::pair<int64_t, std::pair<int64_t, int64_t>>> cameras() {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(db_, "SELECT camera_id, width, height FROM cameras ORDER BY camera_id", -1, &st, nullptr) !=
        SQLITE_OK)
      fail(path_, std::string("not a COLMAP database (") + sqlite3_errmsg(db_) + ")");
    std::vector<std::pair<int64_t, std::pair<int64_t, int64_t>>> out;
    while (sqlite3_step(st) == SQLITE_ROW)
      out.push_back({sqlite3_column_int64(st, 0), {sqlite3_column_int64(st, 1), sqlite3_column_int64(st, 2)}});
    sqlite3_finalize(st);
    return out;
  }

 private:
  std::string path_;
  sqlite3* db_ = nullptr;
};

}  // namespace

int share_cameras_by_image_size(const std::string& database) {
  Connection db(database);
  std::map<std::pair<int64_t, int64_t>, int64_t> first_of_size;
  std::string sql = "BEGIN;";
  for (const auto& [id, size] : db.cameras()) {
    const auto [it, added] = first_of_size.emplace(size, id);
    if (added) continue;
    sql += "UPDATE images SET camera_id = " + std::to_string(it->second) + " WHERE camera_id = " + std::to_string(id) +
           "; DELETE FROM cameras WHERE camera_id = " + std::to_string(id) + ";";
  }
  db.exec(sql + "COMMIT;");
  return static_cast<int>(first_of_size.size());
}

}  // namespace lrf
