#include "lrf/points/colmap_triangulation.h"

#include <sqlite3.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>

#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/core/log.h"
#include "lrf/points/view_pairs.h"
#include "lrf/scene/colmap_model.h"
#include "lrf/scene/colmap_program.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {

// COLMAP's own output goes to the log; the terminal names the step.
void run_step(const std::string& colmap, const std::string& step, const std::vector<std::string>& args,
              const std::string& log) {
  log_info("colmap " + step);
  run_colmap(colmap, step, args, log);
}

class Database {
 public:
  explicit Database(const std::string& path) : path_(path) {
    if (sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READWRITE, nullptr) != SQLITE_OK) {
      std::string msg = db_ ? sqlite3_errmsg(db_) : "cannot open";
      sqlite3_close(db_);
      fail(path, "cannot open COLMAP's database: " + msg);
    }
  }
  ~Database() { sqlite3_close(db_); }
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;

  // image name -> (image_id, camera_id)
  std::map<std::string, std::pair<int64_t, int64_t>> images() {
    std::map<std::string, std::pair<int64_t, int64_t>> out;
    sqlite3_stmt* st = prepare("SELECT image_id, name, camera_id FROM images");
    while (sqlite3_step(st) == SQLITE_ROW) {
      const char* name = reinterpret_cast<const char*>(sqlite3_column_text(st, 1));
      if (name) out[name] = {sqlite3_column_int64(st, 0), sqlite3_column_int64(st, 2)};
    }
    sqlite3_finalize(st);
    return out;
  }

  // Sets a camera to lrf's pinhole intrinsics (COLMAP's PINHOLE model, id 1), marked as known.
  void set_pinhole(int64_t camera_id, const Camera& c) {
    const double params[4] = {c.fx, c.fy, c.cx, c.cy};
    sqlite3_stmt* st = prepare("UPDATE cameras SET model = 1, width = ?, height = ?, params = ?, prior_focal_length = 1 "
                               "WHERE camera_id = ?");
    sqlite3_bind_int64(st, 1, c.width);
    sqlite3_bind_int64(st, 2, c.height);
    sqlite3_bind_blob(st, 3, params, sizeof params, SQLITE_TRANSIENT);
    sqlite3_bind_int64(st, 4, camera_id);
    const int rc = sqlite3_step(st);
    sqlite3_finalize(st);
    if (rc != SQLITE_DONE) fail(path_, std::string("cannot update camera: ") + sqlite3_errmsg(db_));
  }

 private:
  sqlite3_stmt* prepare(const char* sql) {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(db_, sql, -1, &st, nullptr) != SQLITE_OK) {
      fail(path_, std::string("unexpected COLMAP database layout (") + sqlite3_errmsg(db_) + ")");
    }
    return st;
  }
  std::string path_;
  sqlite3* db_ = nullptr;
};

std::string image_file_name(int view) {
  char name[32];
  std::snprintf(name, sizeof name, "view_%05d.png", view);
  return name;
}

}  // namespace

TriangulatedPoints triangulate_with_colmap(const Scene& scene, const TriangulationOptions& t,
                                           const ColmapTriangulationOptions& o) {
  if (!colmap_available(o.colmap)) {
    fail("--with colmap: cannot run '" + o.colmap + "': COLMAP is not installed here (Debian: apt-get install colmap) "
         "or not on PATH; lrf's own triangulation (--with lrf) needs no COLMAP");
  }
  std::vector<int> ids;
  if (t.training_views_only) {
    ids = scene.train_indices;
  } else {
    for (size_t i = 0; i < scene.views.size(); ++i) ids.push_back(static_cast<int>(i));
  }
  if (ids.size() < 2) fail(scene.root, "triangulation needs at least two views with known poses");

  const bool own_dir = o.work_dir.empty();
  fs::path work = own_dir ? fs::temp_directory_path() / ("lrf-colmap-" + std::to_string(::getpid())) : fs::path(o.work_dir);
  if (fs::exists(work / "database.db")) fail((work / "database.db").string(), "exists: give an empty --colmap-work folder");
  fs::create_directories(work / "images");
  fs::create_directories(work / "known");
  fs::create_directories(work / "triangulated");
  const std::string log = (work / "colmap.log").string();
  const std::string db_path = (work / "database.db").string();
  log_info("COLMAP work folder " + work.string() + " (log: " + log + ")");

  // The views as lrf sees them: undistorted, at the resolution in use, pinhole cameras.
  for (int i : ids) write_image_rgb((work / "images" / image_file_name(i)).string(), scene.load_image_u8(i));
  const std::string threads = std::to_string(o.threads > 0 ? o.threads : -1);
  run_step(o.colmap, "feature_extractor",
             {"--database_path", db_path, "--image_path", (work / "images").string(), "--ImageReader.camera_model",
              "PINHOLE", "--SiftExtraction.use_gpu", "0", "--SiftExtraction.num_threads", threads,
              "--SiftExtraction.max_num_features", std::to_string(t.match.max_features)},
             log);

  std::ostringstream cameras, images;
  cameras.precision(17);
  images.precision(17);
  {
    Database db(db_path);
    auto listed = db.images();
    for (int i : ids) {
      auto it = listed.find(image_file_name(i));
      if (it == listed.end()) fail(db_path, "COLMAP did not register " + image_file_name(i));
      const Camera& c = scene.views[static_cast<size_t>(i)].camera;
      const auto [image_id, camera_id] = it->second;
      db.set_pinhole(camera_id, c);
      cameras << camera_id << " PINHOLE " << c.width << " " << c.height << " " << c.fx << " " << c.fy << " " << c.cx
              << " " << c.cy << "\n";
      Eigen::Vector4d q = rotation_to_quaternion(c.R);
      images << image_id << " " << q[0] << " " << q[1] << " " << q[2] << " " << q[3] << " " << c.t[0] << " " << c.t[1]
             << " " << c.t[2] << " " << camera_id << " " << image_file_name(i) << "\n\n";
    }
  }
  write_file_atomic((work / "known" / "cameras.txt").string(), cameras.str());
  write_file_atomic((work / "known" / "images.txt").string(), images.str());
  write_file_atomic((work / "known" / "points3D.txt").string(), "");

  std::ostringstream pairs;
  for (auto [a, b] : overlapping_view_pairs(scene, ids, t.neighbours)) pairs << image_file_name(a) << " " << image_file_name(b) << "\n";
  write_file_atomic((work / "pairs.txt").string(), pairs.str());
  run_step(o.colmap, "matches_importer",
             {"--database_path", db_path, "--match_list_path", (work / "pairs.txt").string(), "--match_type", "pairs",
              "--SiftMatching.use_gpu", "0", "--SiftMatching.num_threads", threads},
             log);
  run_step(o.colmap, "point_triangulator",
             {"--database_path", db_path, "--image_path", (work / "images").string(), "--input_path",
              (work / "known").string(), "--output_path", (work / "triangulated").string(),
              "--Mapper.ba_refine_focal_length", "0", "--Mapper.ba_refine_principal_point", "0",
              "--Mapper.ba_refine_extra_params", "0", "--Mapper.num_threads", threads},
             log);

  ColmapModel model = read_colmap_model((work / "triangulated").string());
  TriangulatedPoints result;
  result.matches_from = "colmap";
  for (const auto& p : model.points) {
    TriangulatedPoint tp;
    tp.xyz = p.xyz;
    tp.rgb = p.rgb;
    tp.error_px = p.error;
    result.points.push_back(tp);
  }
  // Observation-level statistics from the model's own tracks.
  std::vector<double> errors;
  std::map<int64_t, const ColmapPoint*> by_id;
  for (const auto& p : model.points) by_id[p.id] = &p;
  std::map<int64_t, int> track_length;
  std::map<std::string, int> view_of_name;
  for (int i : ids) view_of_name[image_file_name(i)] = i;
  for (const auto& im : model.images) {
    const Camera& c = scene.views[static_cast<size_t>(view_of_name.at(im.name))].camera;
    for (size_t k = 0; k < im.xys.size(); ++k) {
      auto it = by_id.find(im.point3d_ids[k]);
      if (it == by_id.end()) continue;
      Eigen::Vector2d px;
      if (c.project(it->second->xyz, &px)) errors.push_back((px - im.xys[k]).norm());
      ++track_length[im.point3d_ids[k]];
    }
  }
  TriangulationStats& s = result.stats;
  s.views = ids.size();
  s.points = result.points.size();
  if (!errors.empty()) {
    double sum = 0;
    for (double e : errors) sum += e;
    s.mean_error_px = sum / errors.size();
    std::nth_element(errors.begin(), errors.begin() + static_cast<std::ptrdiff_t>(errors.size() / 2), errors.end());
    s.median_error_px = errors[errors.size() / 2];
  }
  double length_sum = 0;
  for (const auto& [id, n] : track_length) length_sum += n;
  s.mean_track_length = track_length.empty() ? 0 : length_sum / track_length.size();
  if (result.points.empty()) fail(log, "COLMAP's point_triangulator kept no point");
  if (own_dir) {
    std::error_code ec;
    fs::remove_all(work, ec);
  }
  return result;
}

}  // namespace lrf
