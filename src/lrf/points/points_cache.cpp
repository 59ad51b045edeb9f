#include "lrf/points/points_cache.h"

#include <filesystem>
#include <sstream>

#include "lrf/core/atomic_file.h"
#include "lrf/core/cache_key.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/run_info.h"
#include "lrf/points/points_file.h"
#include "lrf/scene/colmap_model.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {

void put_camera(std::ostringstream& key, const View& v) {
  const Camera& c = v.camera;
  key << "@" << c.width << "x" << c.height << ":" << c.fx << "," << c.fy << "," << c.cx << "," << c.cy;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) key << "," << c.R(r, k);
  for (int k = 0; k < 3; ++k) key << "," << c.t[k];
  key << ":d";
  for (double d : v.distortion.k) key << "," << d;
  key << (v.distortion.fisheye ? "f" : "") << ":" << v.resize_width << "x" << v.resize_height << "+" << v.crop_x << ","
      << v.crop_y;
}

std::string points_path_for(const std::string& json_path) {
  return (fs::path(json_path).parent_path() / (fs::path(json_path).stem().string() + ".bin")).string();
}

// The entry at `json_path` if it holds `key`; nullopt-like hit=false otherwise (with a warning when it is
// unreadable or belongs to another key).
CachedTriangulation read_entry(const std::string& json_path, const std::string& key) {
  CachedTriangulation entry;
  entry.path = json_path;
  if (!fs::exists(json_path)) return entry;
  try {
    nlohmann::json j = read_json_file(json_path);
    if (j.value("key", std::string()) != key) {
      log_warn(json_path + ": cache key differs (hash collision or edited file); triangulating again");
      return entry;
    }
    entry.stats = j.value("stats", nlohmann::json::object());
    entry.failure = j.value("failure", std::string());
    if (entry.failure.empty()) {
      for (const auto& p : read_colmap_points(points_path_for(json_path))) {
        if (!p.xyz.allFinite()) fail(points_path_for(json_path), "non-finite point");
        TriangulatedPoint t;
        t.xyz = p.xyz;
        t.rgb = p.rgb;
        t.error_px = p.error;
        entry.points.push_back(t);
      }
    }
    entry.hit = true;
  } catch (const std::exception& e) {
    log_warn(std::string("points cache unreadable, triangulating again: ") + e.what());
    entry.points.clear();
    entry.failure.clear();
  }
  return entry;
}

}  // namespace

std::string triangulation_cache_key(const Scene& scene, const TriangulationOptions& o) {
  std::ostringstream key;
  key.precision(17);
  // v2: the images SIFT sees are undistorted with a Lanczos kernel at the file's resolution (v1: bilinearly).
  key << "lrf-points-v2;scene=" << fs::absolute(scene.root).lexically_normal().string();
  key << ";matches=" << (o.database.empty() ? std::string("sift") : file_stamp(o.database));
  const MatchOptions& m = o.match;
  key << ";train_only=" << o.training_views_only << ";neighbours=" << o.neighbours << ";min_inliers=" << m.min_inliers
      << ";min_inlier_ratio=" << m.min_inlier_ratio << ";ratio=" << m.ratio_test << ";ransac=" << m.ransac_threshold_px
      << ";features=" << m.max_features << ";max_error=" << o.max_error_px << ";min_angle=" << o.min_angle_deg
      << ";min_track=" << o.min_track_length << ";seed=" << o.seed;
  std::vector<int> ids;
  if (o.training_views_only) {
    ids = scene.train_indices;
  } else {
    for (size_t i = 0; i < scene.views.size(); ++i) ids.push_back(static_cast<int>(i));
  }
  for (int i : ids) {
    const View& v = scene.views.at(static_cast<size_t>(i));
    key << ";" << v.name << "@" << file_stamp(v.image_path);
    put_camera(key, v);
  }
  return key.str();
}

std::string triangulation_cache_path(const std::string& cache_dir, const std::string& key) {
  return (fs::path(cache_dir) / "points" / (hash_hex(key) + ".json")).string();
}

CachedTriangulation find_cached_triangulation(const Scene& scene, const TriangulationOptions& o,
                                              const std::string& cache_dir) {
  const std::string key = triangulation_cache_key(scene, o);
  return read_entry(triangulation_cache_path(cache_dir, key), key);
}

CachedTriangulation triangulate_cached(const Scene& scene, const TriangulationOptions& o, const std::string& cache_dir) {
  const std::string key = triangulation_cache_key(scene, o);
  const std::string json_path = triangulation_cache_path(cache_dir, key);
  CachedTriangulation entry = read_entry(json_path, key);
  if (entry.hit) return entry;

  nlohmann::json record = {{"key", key}, {"scene", scene.root}};
  try {
    TriangulatedPoints t = triangulate_scene(scene, o);
    entry.points = std::move(t.points);
    entry.stats = t.stats.to_json();
    record["matches_from"] = t.matches_from;
  } catch (const Error& e) {
    entry.failure = e.what();
    record["failure"] = entry.failure;
  }
  record["stats"] = entry.stats;
  record["written_by"] = version_string();
  fs::create_directories(fs::path(json_path).parent_path());
  // Points first, then the record that vouches for them: a reader never sees a record without its points.
  if (entry.failure.empty()) write_points_file(points_path_for(json_path), entry.points);
  write_file_atomic(json_path, record.dump(2) + "\n");
  return entry;
}

}  // namespace lrf
