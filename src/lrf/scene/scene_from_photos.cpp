#include "lrf/scene/scene_from_photos.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <set>
#include <vector>

#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/core/folder_lock.h"
#include "lrf/core/log.h"
#include "lrf/core/progress.h"
#include "lrf/core/stop_request.h"
#include "lrf/scene/colmap_model.h"
#include "lrf/scene/colmap_program.h"
#include "lrf/scene/colmap_cameras_by_size.h"
#include "lrf/scene/colmap_match_report.h"
#include "lrf/scene/photo_import.h"
#include "lrf/scene/step_records.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {

constexpr int kSteps = 6;

// The absolute, normalised form of a path that may not exist yet, without a trailing separator.
fs::path normalised(const std::string& path) {
  fs::path p = fs::weakly_canonical(fs::absolute(path)).lexically_normal();
  if (p.filename().empty()) p = p.parent_path();
  return p;
}

bool is_within(const fs::path& inner, const fs::path& outer) {
  auto i = inner.begin();
  for (auto o = outer.begin(); o != outer.end(); ++o, ++i) {
    if (i == inner.end() || *i != *o) return false;
  }
  return true;
}

void check_options(const SceneFromPhotosOptions& o) {
  static const std::set<std::string> matchers = {"auto", "exhaustive", "sequential"};
  if (!matchers.count(o.matcher)) fail_usage("--matcher must be auto, exhaustive or sequential");
  static const std::set<std::string> models = {"OPENCV", "SIMPLE_RADIAL", "RADIAL", "PINHOLE", "SIMPLE_PINHOLE"};
  if (!models.count(o.camera_model)) {
    fail_usage("--camera-model must be OPENCV, SIMPLE_RADIAL, RADIAL, PINHOLE or SIMPLE_PINHOLE");
  }
  if (o.max_side < 0) fail_usage("--max-side must be 0 (keep the photos' size) or a number of pixels");
  if (o.max_side > 0 && o.max_side < 64) fail_usage("--max-side " + std::to_string(o.max_side) + " is too small for "
                                                    "feature matching (64 pixels at least)");
  if (o.scene.empty()) fail_usage("give the scene folder to write with -o");
  const fs::path photos = normalised(o.photos), scene = normalised(o.scene);
  // The photos folder is never written to, and --force never removes anything of it.
  if (is_within(scene, photos)) {
    fail_usage("the scene folder " + o.scene + " lies inside the photos folder " + o.photos +
               ", which lrf scene create never writes to: choose a scene folder elsewhere");
  }
  if (is_within(photos, scene)) {
    fail_usage("the photos folder " + o.photos + " lies inside the scene folder " + o.scene +
               ", which lrf scene create writes (and --force clears): keep the photos elsewhere");
  }
}

// What an earlier run may have left in the scene folder; --force removes these and nothing else.
const char* const kOwnEntries[] = {"colmap", "colmap.log", "images", "sparse", "images.partial", "sparse.partial"};

// The scene folder may be new, empty, or an earlier run's (to resume); anything else is the user's.
void check_scene_folder(const std::string& folder) {
  const fs::path scene(folder);
  std::error_code ec;
  if (!fs::exists(scene, ec)) return;
  if (!fs::is_directory(scene, ec)) fail(folder, "exists and is not a folder");
  if (!fs::is_empty(scene, ec) && !fs::is_directory(scene / "colmap", ec) && !fs::exists(scene / "colmap.log", ec)) {
    fail(folder, "exists, is not empty and was not written by lrf scene create (it has neither a colmap/ work "
                 "folder nor colmap.log): give a new or empty folder");
  }
}

void prepare_scene_folder(const SceneFromPhotosOptions& o) {
  const fs::path scene(o.scene);
  if (o.force) {
    for (const char* entry : kOwnEntries) fs::remove_all(scene / entry);
  }
  fs::create_directories(scene / "colmap");
}

// A heading in the log before each COLMAP step, so that a failure's output is easy to find.
void log_heading(const std::string& log, const std::string& text) {
  std::ofstream out(log, std::ios::app);
  out << "\n==== lrf scene create: " << text << " ====\n";
}

std::string count_of(size_t n, const std::string& what) { return std::to_string(n) + " " + what + (n == 1 ? "" : "s"); }

// The mapper's models (sparse/0, sparse/1, ...) with the number of photos each registered.
std::vector<std::pair<std::string, size_t>> mapper_models(const fs::path& sparse) {
  std::vector<std::pair<std::string, size_t>> models;
  std::error_code ec;
  if (!fs::is_directory(sparse, ec)) return models;
  for (const auto& e : fs::directory_iterator(sparse)) {
    if (!e.is_directory() || !fs::exists(e.path() / "images.bin")) continue;
    models.emplace_back(e.path().string(), read_colmap_images((e.path() / "images.bin").string()).size());
  }
  std::sort(models.begin(), models.end(), [](const auto& a, const auto& b) {
    return a.second != b.second ? a.second > b.second : a.first < b.first;
  });
  return models;
}

// Hard links where the filesystem allows (no second copy of the images), else copies.
void link_or_copy(const fs::path& from, const fs::path& to) {
  std::error_code ec;
  fs::create_hard_link(from, to, ec);
  if (ec) fs::copy_file(from, to, fs::copy_options::overwrite_existing);
}

// Publishes the undistorted model as the scene: the old sparse/ goes first (the folder stops being a scene
// lrf reads), then images/, and the new sparse/ arrives last, by a rename.
void publish_scene(const fs::path& undistorted, const fs::path& scene) {
  fs::remove_all(scene / "sparse");
  fs::remove_all(scene / "images");
  fs::remove_all(scene / "images.partial");
  fs::remove_all(scene / "sparse.partial");
  fs::create_directories(scene / "images.partial");
  for (const auto& e : fs::directory_iterator(undistorted / "images")) {
    if (e.is_regular_file()) link_or_copy(e.path(), scene / "images.partial" / e.path().filename());
  }
  fs::rename(scene / "images.partial", scene / "images");
  fs::create_directories(scene / "sparse.partial" / "0");
  for (const char* name : {"cameras.bin", "images.bin", "points3D.bin"}) {
    fs::copy_file(undistorted / "sparse" / name, scene / "sparse.partial" / "0" / name);
  }
  fs::rename(scene / "sparse.partial", scene / "sparse");
}

class StepTimer {
 public:
  StepTimer() : start_(std::chrono::steady_clock::now()) {}
  std::string elapsed() const {
    return Progress::format_duration(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count());
  }

 private:
  std::chrono::steady_clock::time_point start_;
};

// Undistortion keeps the part of a photo that its fitted lens maps inside a rectangle; a badly fitted
// distortion leaves a sliver (80x60 of a 400x300 photo was seen), which would train a field on almost
// nothing. Views kept at under 0.4 of a photo's width or height count as collapsed.
struct CollapsedViews {
  int count = 0;
  std::string listed;  // the first five, one per line: name, kept size, photo size
};

CollapsedViews collapsed_undistortion(const fs::path& model, const std::vector<PreparedPhoto>& photos) {
  const auto cameras = read_colmap_cameras((model / "cameras.bin").string());
  CollapsedViews collapsed;
  for (const auto& image : read_colmap_images((model / "images.bin").string())) {
    const auto photo = std::find_if(photos.begin(), photos.end(), [&](const auto& p) { return p.name == image.name; });
    const auto camera = cameras.find(image.camera_id);
    if (photo == photos.end() || camera == cameras.end()) continue;
    const auto& c = camera->second;
    // Widening by up to 2x and then --max_image_size's cap can leave 0.5 of a side legitimately; the
    // failures seen kept 0.2.
    const double kept_w = double(c.width) / photo->width, kept_h = double(c.height) / photo->height;
    if (std::min(kept_w, kept_h) < 0.4) {
      ++collapsed.count;
      if (collapsed.count <= 5)
        collapsed.listed += "\n  " + image.name + ": " + std::to_string(c.width) + "x" + std::to_string(c.height) +
                            " of its " + std::to_string(photo->width) + "x" + std::to_string(photo->height);
    }
  }
  return collapsed;
}

std::string step_label(int step) { return "[" + std::to_string(step) + "/" + std::to_string(kSteps) + "] "; }

// What steps 2 to 5 share: the options, the prepared photos and the work folder's files.
struct ColmapWork {
  const SceneFromPhotosOptions& options;
  const std::vector<PreparedPhoto>& prepared;
  fs::path work;
  std::string log, images, database, threads;
};

// Steps 2 to 5 (features, matches, mapper, undistortion) with one camera model; `result` gets the counts.
// The undistorted model is left in work/undistorted.
void reconstruct(const ColmapWork& w, const std::string& camera_model, StepRecords& records,
                 SceneFromPhotosResult& result) {
  const SceneFromPhotosOptions& o = w.options;
  const std::vector<PreparedPhoto>& prepared = w.prepared;
  const int n = static_cast<int>(prepared.size());
  const fs::path& work = w.work;
  const std::string &log = w.log, &images = w.images, &database = w.database, &threads = w.threads;

  // 2. Features. A phone capture is one camera at one zoom, so one camera shared by every photo: its
  // intrinsics are then fitted to all of them at once, which keeps the focal length well determined even
  // from few photos. OPENCV (focal lengths, principal point, two radial and two tangential terms) covers
  // what is left of a phone lens's distortion, and undistortion at the end turns it into the pinhole
  // cameras lrf works with. Photos of different sizes cannot share a camera: those of each size share one
  // (colmap_cameras_by_size.h says why not one per photo).
  bool shared_camera = true;
  for (const auto& p : prepared) {
    shared_camera = shared_camera && p.width == prepared.front().width && p.height == prepared.front().height;
  }
  const std::string matcher =
      o.matcher != "auto" ? o.matcher : n <= o.exhaustive_up_to ? "exhaustive" : "sequential";
  // The matches are stored in the database the features start, so another matcher starts a fresh one.
  std::set<std::pair<int, int>> sizes;
  for (const auto& p : prepared) sizes.insert({p.width, p.height});
  const std::string feature_settings = "camera_model " + camera_model + "\nshared_camera " +
                                       std::to_string(shared_camera) + "\ncameras per size\nmatcher " + matcher;
  if (records.skip("features", feature_settings, fs::exists(database))) {
    log_info(step_label(2) + "features: already extracted (" + database + ")");
  } else {
    log_info(step_label(2) + "features: SIFT on " + count_of(prepared.size(), "photo") + ", " +
             (shared_camera ? "one " + camera_model + " camera shared by all"
                            : "one " + camera_model + " camera for each of the " +
                                  std::to_string(sizes.size()) + " photo sizes"));
    StepTimer t;
    fs::remove(database);
    log_heading(log, "colmap feature_extractor");
    run_colmap(o.colmap, "feature_extractor",
               {"--database_path", database, "--image_path", images, "--ImageReader.camera_model", camera_model,
                "--ImageReader.single_camera", shared_camera ? "1" : "0", "--SiftExtraction.use_gpu", "0",
                "--SiftExtraction.num_threads", threads},
               log);
    if (!shared_camera) share_cameras_by_image_size(database);
    records.finished("features");
    log_info("    done in " + t.elapsed());
  }

  // 3. Matches: every pair while that stays affordable; above, each photo with its neighbours in name
  // order (a capture taken walking around the subject, as phones name photos in the order taken).
  if (records.skip("matches", "", fs::exists(database))) {
    log_info(step_label(3) + "matches: already matched (" + matcher + ")");
  } else {
    const size_t pairs = static_cast<size_t>(n) * static_cast<size_t>(n - 1) / 2;
    log_info(step_label(3) + "matches: " +
             (matcher == "exhaustive" ? "every pair of the " + count_of(prepared.size(), "photo") + " (" +
                                            std::to_string(pairs) + " pairs)"
                                      : "each of the " + count_of(prepared.size(), "photo") +
                                            " with its neighbours in name order (sequential)"));
    StepTimer t;
    log_heading(log, "colmap " + matcher + "_matcher");
    run_colmap(o.colmap, matcher + "_matcher",
               {"--database_path", database, "--SiftMatching.use_gpu", "0", "--SiftMatching.num_threads", threads},
               log);
    records.finished("matches");
    log_info("    done in " + t.elapsed());
  }

  // 4. Poses and points. The mapper may split the photos into several unconnected models.
  const fs::path sparse = work / "sparse";
  const std::string mapper_settings = "init_min_inliers " + std::to_string(o.init_min_inliers);
  if (records.skip("mapper", mapper_settings, !mapper_models(sparse).empty())) {
    log_info(step_label(4) + "mapper: already reconstructed (" + sparse.string() + ")");
  } else {
    log_info(step_label(4) + "mapper: camera poses and 3D points from " + count_of(prepared.size(), "photo"));
    StepTimer t;
    fs::remove_all(sparse);
    fs::create_directories(sparse);
    log_heading(log, "colmap mapper");
    // A model smaller than the rule below accepts is dropped by the mapper itself, which then starts again
    // from another pair of photos: with a dozen photos, its first model sometimes holds only 3.
    try {
      run_colmap(o.colmap, "mapper",
                 {"--database_path", database, "--image_path", images, "--output_path", sparse.string(),
                  "--Mapper.num_threads", threads, "--Mapper.min_model_size",
                  std::to_string(min_registered_photos(n)), "--Mapper.init_min_num_inliers",
                  std::to_string(o.init_min_inliers)},
                 log);
    } catch (const Interrupted&) {
      throw;
    } catch (const Error& e) {
      // Its usual reason is none of COLMAP's own words: the photos did not match. What the matcher found
      // says how badly, and what to change.
      throw Error(std::string(e.what()) + describe_matches(database, o.init_min_inliers));
    }
    records.finished("mapper");
    log_info("    done in " + t.elapsed());
  }
  const auto models = mapper_models(sparse);
  if (models.empty()) {
    fail(log, "COLMAP's mapper could not reconstruct any part of the scene from the " +
                  count_of(prepared.size(), "photo") + ".\n" + describe_matches(database, o.init_min_inliers));
  }
  result.photos = n;
  result.models = static_cast<int>(models.size());
  result.registered = static_cast<int>(models.front().second);
  if (models.size() > 1) {
    std::string sizes;
    for (const auto& m : models) sizes += (sizes.empty() ? "" : ", ") + std::to_string(m.second);
    log_warn("COLMAP's mapper made " + std::to_string(models.size()) + " separate models (" + sizes +
             " photos), which do not connect: keeping the largest, " + models.front().first +
             "; photos of the others are left out");
  }
  if (result.registered < min_registered_photos(n)) {
    fail(o.photos, "COLMAP registered only " + std::to_string(result.registered) + " of the " +
                       count_of(prepared.size(), "photo") + " in one model; lrf scene create needs at least " +
                       std::to_string(min_registered_photos(n)) + " (3, and half of the photos). Photos need "
                       "to overlap well (each part of the scene in several photos, from nearby viewpoints) and "
                       "to be sharp; COLMAP's output is in " + log);
  }
  log_info("    registered " + std::to_string(result.registered) + " of " + count_of(prepared.size(), "photo"));

  // 5. Undistortion to pinhole cameras: the images and model lrf reads.
  const fs::path undistorted = work / "undistorted";
  const bool undistorted_present = fs::exists(undistorted / "sparse" / "images.bin") &&
                                   fs::exists(undistorted / "sparse" / "cameras.bin") &&
                                   fs::exists(undistorted / "sparse" / "points3D.bin");
  if (records.skip("undistort", "model " + fs::path(models.front().first).filename().string(),
                   undistorted_present)) {
    log_info(step_label(5) + "undistort: already done (" + undistorted.string() + ")");
  } else {
    log_info(step_label(5) + "undistort: " + count_of(static_cast<size_t>(result.registered), "image") +
             " to PINHOLE cameras");
    StepTimer t;
    fs::remove_all(undistorted);
    log_heading(log, "colmap image_undistorter");
    // Undistorting can widen the image (by up to twice, to keep every photographed pixel), so the
    // longer side is capped again here: --max-side promises the scene's images, not only the photos.
    std::vector<std::string> undistort_args = {"--image_path", images, "--input_path", models.front().first,
                                               "--output_path", undistorted.string(), "--output_type", "COLMAP"};
    if (o.max_side > 0) {
      undistort_args.push_back("--max_image_size");
      undistort_args.push_back(std::to_string(o.max_side));
    }
    run_colmap(o.colmap, "image_undistorter", undistort_args, log);
    records.finished("undistort");
    log_info("    done in " + t.elapsed());
  }
}

}  // namespace

int min_registered_photos(int photos) { return std::max(3, (photos + 1) / 2); }

SceneFromPhotosResult create_scene_from_photos(const SceneFromPhotosOptions& o) {
  check_options(o);
  const std::vector<std::string> names = list_photos(o.photos);
  const int n = static_cast<int>(names.size());
  if (n < 3) {
    fail(o.photos, "holds " + count_of(names.size(), "photo") + "; structure from motion needs at least 3 "
                   "overlapping photos of the scene (a few dozen, taken while walking around it, work best)");
  }
  check_scene_folder(o.scene);
  if (!colmap_available(o.colmap)) {
    fail("cannot run '" + o.colmap + "': COLMAP is not installed or not on PATH. lrf scene create runs COLMAP "
         "(3.8 or later) for structure from motion; install it with `apt-get install colmap` (Debian, Ubuntu), "
         "which scripts/install-deps.sh tries as an optional package");
  }
  // One run at a time per scene folder, as for training: two would write the same COLMAP database (and
  // --force would clear a folder another run is writing).
  fs::create_directories(o.scene);
  const FolderLock lock(o.scene);
  prepare_scene_folder(o);

  const fs::path scene(o.scene), work = fs::path(o.scene) / "colmap";
  const std::string log = (scene / "colmap.log").string();
  const std::string images = (work / "images").string(), database = (work / "database.db").string();
  const std::string threads = std::to_string(o.threads > 0 ? o.threads : -1);
  auto records = std::make_unique<StepRecords>(work.string(), o.force);
  log_info("scene " + o.scene + " from " + count_of(names.size(), "photo") + " in " + o.photos +
           " (COLMAP's output goes to " + log + ")");

  // 1. The photos COLMAP sees: copies, upright and downscaled. Their names and sizes key the step, so new,
  // removed or edited photos start it again.
  std::string photo_settings = "max_side " + std::to_string(o.max_side) + "\n";
  for (const auto& name : names) {
    std::error_code ec;
    const fs::path p = fs::path(o.photos) / name;
    photo_settings += name + " " + std::to_string(fs::file_size(p, ec)) + " " +
                      std::to_string(fs::last_write_time(p, ec).time_since_epoch().count()) + "\n";
  }
  const std::string sizes_file = (work / "photo_sizes.txt").string();
  std::vector<PreparedPhoto> prepared;
  if (records->skip("photos", photo_settings, fs::exists(sizes_file))) {
    log_info(step_label(1) + "photos: already prepared in " + images);
    prepared = read_photo_sizes(sizes_file);
  } else {
    log_info(step_label(1) + "photos: copying " + count_of(names.size(), "photo") + " to " + images +
             (o.max_side > 0 ? " (longer side at most " + std::to_string(o.max_side) + " px)" : " (full size)"));
    StepTimer t;
    fs::remove_all(images);
    prepared = prepare_photos(o.photos, names, images, o.max_side);
    write_photo_sizes(sizes_file, prepared);
    records->finished("photos");
    log_info("    done in " + t.elapsed());
  }


  // Steps 2 to 5. OPENCV's four distortion terms, fitted to a dozen photos of one size, sometimes run away
  // (on one machine and not on another: SIFT's and the mapper's threads reorder their work), and
  // undistortion then keeps a sliver of those photos. SIMPLE_RADIAL's single term does not, so a collapse
  // under the default model is retried once with it before giving up. A marker keyed on the photos lets a
  // resumed run go straight to the model that worked.
  ColmapWork w{o, prepared, work, log, images, database, threads};
  const fs::path undistorted = work / "undistorted";
  const std::string fallback_model = "SIMPLE_RADIAL", marker = (work / "camera_model_fallback.txt").string();
  std::string camera_model = o.camera_model;
  if (camera_model == "OPENCV" && !o.force && fs::exists(marker) && read_file(marker) == photo_settings) {
    camera_model = fallback_model;
    records = std::make_unique<StepRecords>(work.string(), false);
    records->skip("photos", photo_settings, true);
    log_info("    " + fallback_model + " cameras, as in the earlier run (OPENCV's distortion fit ran away)");
  }
  SceneFromPhotosResult result;
  reconstruct(w, camera_model, *records, result);
  CollapsedViews collapsed = collapsed_undistortion(undistorted / "sparse", prepared);
  if (collapsed.count > 0 && camera_model == "OPENCV") {
    log_warn("OPENCV's distortion, fitted badly, left only a small part of " +
             count_of(static_cast<size_t>(collapsed.count), "photo") + " after undistortion:" + collapsed.listed +
             "\nfitting the cameras again as " + fallback_model + " (one radial term)");
    camera_model = fallback_model;
    write_file_atomic(marker, photo_settings);
    records = std::make_unique<StepRecords>(work.string(), false);
    records->skip("photos", photo_settings, true);
    reconstruct(w, camera_model, *records, result);
    collapsed = collapsed_undistortion(undistorted / "sparse", prepared);
  }
  if (collapsed.count > 0) {
    fail(o.photos, "COLMAP's undistortion kept only a small part of " + std::to_string(collapsed.count) + " photo" +
                       (collapsed.count == 1 ? "" : "s") + ", whose lens distortion was fitted badly (" +
                       camera_model + " cameras):" + collapsed.listed +
                       "\nRemove these photos, or add more photos of the same size (a camera is fitted to the "
                       "photos of each size together), or try --camera-model " +
                       (camera_model == "SIMPLE_RADIAL" ? "PINHOLE, which fits no distortion"
                                                        : "SIMPLE_RADIAL, which fits fewer distortion terms"));
  }

  // 6. The scene itself.
  if (records->skip("scene", "", fs::exists(scene / "sparse" / "0" / "images.bin") && fs::is_directory(scene / "images"))) {
    log_info(step_label(6) + "scene: already written (" + o.scene + ")");
  } else {
    log_info(step_label(6) + "scene: writing " + (scene / "images").string() + " and " +
             (scene / "sparse" / "0").string());
    publish_scene(undistorted, scene);
    records->finished("scene");
  }
  result.points = read_colmap_points((scene / "sparse" / "0" / "points3D.bin").string()).size();
  return result;
}

}  // namespace lrf
