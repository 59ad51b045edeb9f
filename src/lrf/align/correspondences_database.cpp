// Correspondences from a COLMAP database.db: the inlier matches of its two-view geometries, with the
// keypoints' coordinates mapped to the scene's resolution in use.
#include <sqlite3.h>

#include <cstring>
#include <filesystem>
#include <map>
#include <unordered_map>

#include "lrf/align/correspondences_database.h"
#include "lrf/core/error.h"

namespace lrf {
namespace {

constexpr int64_t kMaxImageId = 2147483647;  // COLMAP's pair_id = id1 * kMaxImageId + id2

class Database {
 public:
  explicit Database(const std::string& path) : path_(path) {
    if (!std::filesystem::is_regular_file(path)) fail(path, "COLMAP database not found");
    if (sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
      std::string msg = db_ ? sqlite3_errmsg(db_) : "cannot open";
      sqlite3_close(db_);
      fail(path, "cannot open as SQLite: " + msg);
    }
  }
  ~Database() { sqlite3_close(db_); }
  sqlite3_stmt* prepare(const char* sql) {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(db_, sql, -1, &st, nullptr) != SQLITE_OK) {
      fail(path_, std::string("not a COLMAP database (") + sqlite3_errmsg(db_) + ")");
    }
    return st;
  }

 private:
  std::string path_;
  sqlite3* db_ = nullptr;
};

}  // namespace

CorrespondenceSet correspondences_from_database(const Scene& scene, const std::string& path, int min_matches,
                                                bool training_only) {
  Database db(path);
  std::unordered_map<std::string, int> view_of_name;
  for (int i = 0; i < static_cast<int>(scene.views.size()); ++i) {
    view_of_name[scene.views[i].name] = i;
    view_of_name[std::filesystem::path(scene.views[i].name).filename().string()] = i;
  }
  std::vector<bool> ok(scene.views.size(), !training_only);
  if (training_only) {
    for (int i : scene.train_indices) ok[i] = true;
  }

  std::map<int64_t, int> view_of_image;  // COLMAP image_id -> view index
  sqlite3_stmt* st = db.prepare("SELECT image_id, name FROM images");
  while (sqlite3_step(st) == SQLITE_ROW) {
    int64_t id = sqlite3_column_int64(st, 0);
    const char* name = reinterpret_cast<const char*>(sqlite3_column_text(st, 1));
    if (name && view_of_name.count(name)) view_of_image[id] = view_of_name[name];
  }
  sqlite3_finalize(st);
  if (view_of_image.empty()) fail(path, "no image of the database matches a view of " + scene.root);

  std::map<int64_t, std::vector<Eigen::Vector2d>> keypoints;  // in view pixels
  st = db.prepare("SELECT image_id, rows, cols, data FROM keypoints");
  while (sqlite3_step(st) == SQLITE_ROW) {
    int64_t id = sqlite3_column_int64(st, 0);
    int64_t rows = sqlite3_column_int64(st, 1), cols = sqlite3_column_int64(st, 2);
    const void* blob = sqlite3_column_blob(st, 3);
    int64_t bytes = sqlite3_column_bytes(st, 3);
    if (!view_of_image.count(id) || rows <= 0) continue;
    if (cols < 2 || cols > 6 || rows > bytes || rows * cols * 4 != bytes) {
      sqlite3_finalize(st);
      fail(path, "keypoints of image " + std::to_string(id) + " have an inconsistent size");
    }
    std::vector<Eigen::Vector2d> px(rows);
    const float* f = static_cast<const float*>(blob);
    for (int64_t r = 0; r < rows; ++r) px[r] = Eigen::Vector2d(f[r * cols], f[r * cols + 1]);
    keypoints[id] = nominal_to_view_pixels(scene.views[view_of_image[id]], px);
  }
  sqlite3_finalize(st);

  CorrespondenceSet set = empty_correspondences(scene, "colmap-db");
  st = db.prepare("SELECT pair_id, rows, cols, data FROM two_view_geometries WHERE rows > 0");
  while (sqlite3_step(st) == SQLITE_ROW) {
    int64_t pair = sqlite3_column_int64(st, 0);
    int64_t rows = sqlite3_column_int64(st, 1), cols = sqlite3_column_int64(st, 2);
    int64_t bytes = sqlite3_column_bytes(st, 3);
    const uint32_t* idx = static_cast<const uint32_t*>(sqlite3_column_blob(st, 3));
    if (cols != 2 || rows * 8 != bytes) {
      sqlite3_finalize(st);
      fail(path, "two-view geometry " + std::to_string(pair) + " has an inconsistent size");
    }
    int64_t id2 = pair % kMaxImageId, id1 = (pair - id2) / kMaxImageId;
    if (!view_of_image.count(id1) || !view_of_image.count(id2) || !keypoints.count(id1) || !keypoints.count(id2)) continue;
    int vi = view_of_image[id1], vj = view_of_image[id2];
    if (!ok[vi] || !ok[vj]) continue;
    const auto& ki = keypoints[id1];
    const auto& kj = keypoints[id2];
    ViewPairMatches m;
    bool swap = vi > vj;
    m.view_i = swap ? vj : vi;
    m.view_j = swap ? vi : vj;
    for (int64_t r = 0; r < rows; ++r) {
      uint32_t a = idx[2 * r], b = idx[2 * r + 1];
      if (a >= ki.size() || b >= kj.size()) {
        sqlite3_finalize(st);
        fail(path, "match index out of range in two-view geometry " + std::to_string(pair));
      }
      Eigen::Vector2f pa = ki[a].cast<float>(), pb = kj[b].cast<float>();
      m.xi.push_back(swap ? pb : pa);
      m.xj.push_back(swap ? pa : pb);
    }
    if (static_cast<int>(m.xi.size()) >= min_matches) set.pairs.push_back(std::move(m));
  }
  sqlite3_finalize(st);
  if (set.pairs.empty()) fail(path, "no two-view geometry with at least " + std::to_string(min_matches) + " inliers");
  return set;
}

}  // namespace lrf
