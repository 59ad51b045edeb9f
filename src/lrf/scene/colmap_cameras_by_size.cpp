#include "lrf/scene/colmap_cameras_by_size.h"

#include <sqlite3.h>

#include <map>
#include <utility>

#include "lrf/scene/colmap_database.h"

namespace lrf {

int share_cameras_by_image_size(const std::string& database) {
  ColmapDatabase db(database, true);
  std::map<std::pair<int64_t, int64_t>, int64_t> first_of_size;
  std::string sql = "BEGIN;";
  db.each_row("SELECT camera_id, width, height FROM cameras ORDER BY camera_id", [&](sqlite3_stmt* st) {
    const int64_t id = sqlite3_column_int64(st, 0);
    const auto [it, added] = first_of_size.emplace(std::make_pair(sqlite3_column_int64(st, 1), sqlite3_column_int64(st, 2)), id);
    if (added) return;
    sql += "UPDATE images SET camera_id = " + std::to_string(it->second) + " WHERE camera_id = " + std::to_string(id) +
           "; DELETE FROM cameras WHERE camera_id = " + std::to_string(id) + ";";
  });
  db.exec(sql + "COMMIT;");
  return static_cast<int>(first_of_size.size());
}

}  // namespace lrf
