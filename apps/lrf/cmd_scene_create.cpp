// lrf scene create: a scene from a folder of plain photos, through COLMAP's structure from motion.
#include <cstdio>
#include <memory>

#include "command.h"
#include "lrf/core/threads.h"
#include "lrf/scene/scene_from_photos.h"

namespace {

int run_create(lrf::SceneFromPhotosOptions o) {
  o.threads = lrf::thread_count();
  const lrf::SceneFromPhotosResult r = lrf::create_scene_from_photos(o);
  std::printf("scene      %s\nviews      %d of %d photos registered%s\npoints     %zu\nnext       lrf train %s -o RUN\n",
              o.scene.c_str(), r.registered, r.photos,
              r.models > 1 ? (" (the largest of " + std::to_string(r.models) + " models)").c_str() : "", r.points,
              o.scene.c_str());
  return 0;
}

lrf::cli::CommandRegistration reg(11, [](CLI::App& root) {
  CLI::App* scene = root.get_subcommand("scene");
  auto o = std::make_shared<lrf::SceneFromPhotosOptions>();
  auto* cmd = scene->add_subcommand(
      "create",
      "Make a scene from your own photos: runs COLMAP (the colmap program, 3.8 or later, on the CPU) for camera "
      "poses and points (feature extraction, matching, mapper), then undistorts the photos to pinhole cameras. "
      "SCENE gets images/ and sparse/0/{cameras,images,points3D}.bin (a COLMAP scene, for lrf train), "
      "colmap.log (COLMAP's own output) and colmap/ (its work: prepared photos, database, models; delete it once "
      "the scene is made to save space). The photos folder is only read. A rerun skips the steps already done with the same photos and options (--force "
      "starts over); sparse/ is written last, so an interrupted run never looks like a complete scene. Fails "
      "when COLMAP registers fewer than 3 photos, or fewer than half of them, in one model; when the mapper makes "
      "several unconnected models, the largest is kept and the others' photos are left out");
  cmd->add_option("photos", o->photos, "Folder of photos (.jpg, .jpeg, .png, .bmp, .tif, .tiff, .webp directly "
                                       "inside it), of one scene from many overlapping viewpoints")
      ->required();
  cmd->add_option("-o,--output", o->scene,
                  "Scene folder to write: new, empty, or an earlier lrf scene create's (to resume it)")
      ->required();
  cmd->add_option("--max-side", o->max_side,
                  "Downscale the photos (copies of them) so that their longer side is at most this many pixels "
                  "before COLMAP sees them; the undistorted images of the scene are held to the same bound. 0: keep the "
                  "photos' size")
      ->capture_default_str();
  cmd->add_option("--matcher", o->matcher,
                  "Which photo pairs COLMAP matches: exhaustive (every pair), sequential (each photo with its "
                  "neighbours in file-name order: photos taken in order, e.g. walking around the subject), or auto "
                  "(exhaustive up to " + std::to_string(o->exhaustive_up_to) + " photos, sequential above)")
      ->check(CLI::IsMember({"auto", "exhaustive", "sequential"}))
      ->capture_default_str();
  cmd->add_option("--camera-model", o->camera_model,
                  "COLMAP's camera model, one camera shared by the photos of each size. OPENCV fits a phone lens's remaining distortion (a fit that runs away, leaving slivers after undistortion, is redone once as SIMPLE_RADIAL); PINHOLE or SIMPLE_PINHOLE for "
                  "photos that are already undistorted. The scene's cameras are PINHOLE in every case")
      ->check(CLI::IsMember({"OPENCV", "SIMPLE_RADIAL", "RADIAL", "PINHOLE", "SIMPLE_PINHOLE"}))
      ->capture_default_str();
  cmd->add_option("--init-min-inliers", o->init_min_inliers,
                  "Verified matches the pair of photos COLMAP's mapper starts from must share; lower it (to 50, "
                  "say) when the mapper finds no initial pair and the report shows that the best pairs fall short")
      ->check(CLI::Range(15, 100000))
      ->capture_default_str();
  cmd->add_flag("--force", o->force,
                "Start over: remove what an earlier run left in SCENE (colmap/, colmap.log, images/, sparse/) "
                "instead of resuming it");
  lrf::cli::on_run(cmd, [o] { return run_create(*o); });
});

}  // namespace
