// lrf render: images of a trained field for the scene's cameras, at any resolution; or, with --path, a
// camera-path video (spiral, orbit, interpolation through the training views).
#include <cstdio>
#include <filesystem>
#include <memory>

#include "command.h"
#include "detail_options.h"
#include "lrf/camera_path/camera_path.h"
#include "lrf/detail/detail_frames.h"
#include "lrf/field_kinds/field_type.h"
#include "lrf/frames/field_frames.h"
#include "lrf/video/path_video.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/splat/run/render_size.h"
#include "lrf/splat/run/run_folder.h"
#include "lrf/scene/scene_outputs.h"
#include "scene_override_option.h"

namespace fs = std::filesystem;

namespace {

struct RenderOptions {
  std::string out;
  lrf::ViewRenders views;  // the scene's views; their scale, size and decoder serve --path too
  bool split_given = false;
  // Camera-path videos (--path).
  std::string path;
  lrf::camera_path::PathOptions path_options;
  lrf::video::PathVideoOptions video;
  bool frames_given = false, fps_given = false;
  bool detail = false;
  lrf::detail::DetailOptions detail_options;
};

// --path: the scene's camera path rendered into an MP4 (and PNG frames with --frames-dir).
int run_render_path(const RenderOptions& o) {
  using namespace lrf;
  if (o.split_given) fail_usage("--split chooses the scene's views; a --path video has its own cameras");
  std::unique_ptr<FieldFrames> frames = open_field_frames(o.out, o.views.decoder);
  if (o.detail) frames = std::make_unique<lrf::detail::DetailFrames>(std::move(frames), o.detail_options);
  if (frames->latent() && (o.views.scale != 1.0 || o.views.width > 0))
    fail_usage("--scale/--width/--height apply to RGB fields; latent fields render at their latent resolution and decode at 8x");
  const auto kind = camera_path::parse_path_kind(o.path);
  camera_path::PathGeometry geometry;
  if (!o.video.frames_dir.empty()) refuse_output_in_scene(o.video.frames_dir, frames->scene());
  auto path = camera_path::make_path(frames->scene(), kind, o.path_options, &geometry);
  for (auto& c : path) c = splat::scaled_camera(c, o.views.scale, o.views.width, o.views.height);
  video::PathVideoOptions vo = o.video;
  if (vo.video.empty() && vo.frames_dir.empty()) {
    vo.video = (fs::path(o.out) / "renders" / (o.path + ".mp4")).string();
    fs::create_directories(fs::path(vo.video).parent_path());
  }
  log_info(frames->describe());
  if (kind != camera_path::PathKind::interp) log_info(o.path + " around a target found from " + geometry.source);
  const auto r = video::render_path_video(*frames, path, vo);
  char line[256];
  std::snprintf(line, sizeof line, "%ld frames of %dx%d in %.1f s: %.2f frames/s (render %.1f ms, decode %.1f ms per frame)",
                r.frames, path.front().width, path.front().height, r.seconds, double(r.frames) / r.seconds,
                1000.0 * r.render_seconds / double(r.frames), 1000.0 * r.decode_seconds / double(r.frames));
  log_info(line);
  if (o.detail) {
    std::snprintf(line, sizeof line, "detail pass %.1f ms per frame, borrowing from %zu training views",
                  1000.0 * r.detail_seconds / double(r.frames),
                  static_cast<const lrf::detail::DetailFrames&>(*frames).borrowed_views().size());
    log_info(line);
  }
  if (vo.stability) {
    std::snprintf(line, sizeof line,
                  "stability: consecutive frames differ by %.2f of 255 on average after the field's depth carries "
                  "one onto the next (lower is steadier)", r.warp_error);
    log_info(line);
    std::printf("{\"warp_error\": %.4f, \"frames\": %ld}\n", r.warp_error, r.frames);
  }
  if (!vo.video.empty()) {
    std::snprintf(line, sizeof line, "%g", vo.fps);
    log_info("wrote " + vo.video + " (" + r.codec + ", " + line + " fps)");
  }
  if (!vo.frames_dir.empty()) log_info("wrote " + std::to_string(r.frames) + " PNG frames to " + vo.frames_dir);
  return 0;
}

int run_render(const RenderOptions& o) {
  using namespace lrf;
  splat::check_render_options(o.views.scale, o.views.width, o.views.height);  // before the field is even opened
  if (!o.path.empty()) return run_render_path(o);
  if (!o.video.video.empty() || !o.video.frames_dir.empty() || o.frames_given || o.fps_given || o.video.stability)
    fail_usage("--video, --frames-dir, --frames, --fps and --stability go with --path");
  if (o.detail) fail_usage("--detail goes with --path (lrf eval --detail scores the scene's test views with it)");
  field_type_of(o.out).render_views(o.out, o.views);
  return 0;
}

lrf::cli::CommandRegistration reg(21, [](CLI::App& root) {
  auto* cmd = root.add_subcommand("render", "Render a trained field (lrf train output): PNG images of the scene's views (latent "
                                   "fields and latent NeRFs also write the rendered latents), or a camera-path video with "
                                   "--path");
  auto o = std::make_shared<RenderOptions>();
  cmd->add_option("out", o->out, "Output folder of lrf train or lrf refine, or a method's folder of lrf compare (any "
                                   "kind of field)")->required();
  auto* split = cmd->add_option("--split", o->views.split, "Which views: test, train or all")->capture_default_str();
  cmd->add_option("-o,--dir", o->views.dir, "Folder for the images (default OUT/renders/SPLIT)");
  const std::string most = std::to_string(lrf::splat::kMaxRenderSide);
  auto* scale = cmd->add_option("--scale", o->views.scale, "Resolution relative to training (RGB fields; images of at most " +
                                                         most + " pixels per side)")
                    ->capture_default_str();
  cmd->add_option("--width", o->views.width, "Render width in pixels (with --height; at most " + most + ")")->excludes(scale);
  cmd->add_option("--height", o->views.height, "Render height in pixels (with --width; at most " + most + ")")->excludes(scale);
  cmd->add_option("--decoder", o->views.decoder, "Latent fields and latent NeRFs: decode with these decoder weights (e.g. Stage III's; default: the decoder "
                  "a refined field was fitted through, else the autoencoder's)");
  cmd->add_option("--path", o->path, "Render a camera path instead of the scene's views: spiral (LLFF's spiral around "
                  "the mean training pose, for forward-facing scenes), orbit (a turn around the SfM points' centre, for "
                  "object scenes) or interp (smooth path through the training views)");
  auto* frames = cmd->add_option("--frames", o->path_options.frames, "--path: number of frames (1 to 100000)")->capture_default_str();
  auto* fps = cmd->add_option("--fps", o->video.fps, "--path: frames per second of the video")->capture_default_str();
  cmd->add_option("--video", o->video.video, "--path: the MP4 file to write (H.264; default OUT/renders/PATH.mp4 unless "
                  "--frames-dir is given)");
  cmd->add_option("--frames-dir", o->video.frames_dir, "--path: also (or only) write the frames as PNG files into this folder");
  cmd->add_flag("--detail", o->detail,
                "--path: the detail pass on every frame (the nearest training photographs carried into it with the "
                "field's depth and blended in where they agree; splat fields)");
  lrf::cli::add_detail_options(cmd, &o->detail_options);
  cmd->add_flag("--stability", o->video.stability,
                "--path: measure frame-to-frame stability (the mean difference of consecutive frames after the "
                "field's depth carries one onto the next, in 8-bit levels), printed as JSON too; splat fields");
  lrf::cli::add_scene_override_option(cmd);
  lrf::cli::on_run(cmd, [o, split, frames, fps] {
    o->split_given = split->count() > 0;
    o->frames_given = frames->count() > 0;
    o->fps_given = fps->count() > 0;
    return run_render(*o);
  });
});

}  // namespace
