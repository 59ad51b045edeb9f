#include "lrf/rgb/rgb_train_run.h"

#include <filesystem>

#include <torch/torch.h>

#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/core/log.h"
#include "lrf/core/progress.h"
#include "lrf/core/resources.h"
#include "lrf/core/run_info.h"
#include "lrf/core/training_steps.h"
#include "lrf/rgb/rgb_field.h"
#include "lrf/splat/run/field_kind.h"
#include "lrf/splat/run/run_config.h"
#include "lrf/splat/run/run_folder.h"
#include "lrf/splat/run/train_run.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {

void check_options(const RgbTrainOptions& o) {
  check_init_points_mode(o.init_points.mode);
  if (o.factor < 1) fail_usage("the training views' reduction factor must be at least 1");
  if (o.sh_degree < 0 || o.sh_degree > 3) fail_usage("--sh-degree must be 0..3");
  check_training_steps(o.iters);
  if (!(o.densify_grad > 0)) fail_usage("--densify-grad must be positive");
  if (o.scene_options.downscale < 1) fail_usage("--downscale must be at least 1");
  if (o.coarse_factor < 1) fail_usage("--coarse-factor must be at least 1");
  if (o.coarse_until < -1) fail_usage("--coarse-until must be a step (or -1: where densification ends)");
}

// Under the names of lrf train's flags, which is what recorded_rgb_options and the runs that reuse
// finished fields (compare, pipeline) read.
nlohmann::json options_json(const RgbTrainOptions& o) {
  const SceneOptions& so = o.scene_options;
  nlohmann::json j = splat::fit_options_json(o);
  j.update({{"space", field_kind_name(FieldKind::rgb)}, {"test_list", so.test_list}, {"format", so.format},
            {"crop8", so.crop_to_multiple_of_8}, {"factor", o.factor}, {"mip", o.mip},
            {"white_background", o.white_background}, {"coarse_factor", o.coarse_factor},
            {"coarse_until", o.coarse_until}, {"init_points", o.init_points.mode},
            {"far_shell", o.init_points.shell.points}, {"far_shell_radius", o.init_points.shell.radius_factor}});
  return j;
}

// The training views, reduced by `factor` when it is above 1. At 1 they are rgb_views' (the images as
// loaded), so that a run of lrf train trains on exactly what it did before the factor existed.
std::vector<splat::TrainView> training_views(const Scene& scene, int factor) {
  if (factor == 1) return splat::rgb_views(scene, scene.train_indices);
  std::vector<splat::TrainView> views;
  for (int i : scene.train_indices) {
    const View& v = scene.views[static_cast<size_t>(i)];
    // A size that is a multiple of the factor keeps the reduced intrinsics exact.
    if (v.camera.width % factor || v.camera.height % factor)
      fail(v.image_path, "the view's size " + std::to_string(v.camera.width) + "x" + std::to_string(v.camera.height) +
                             " is not a multiple of the training views' reduction factor " + std::to_string(factor));
    Camera camera = v.camera.resized(v.camera.width / factor, v.camera.height / factor);
    cv::Mat image = resize_area(scene.load_image(i), camera.width, camera.height);
    views.push_back({v.name, camera, splat::image_to_tensor(image)});
  }
  return views;
}

}  // namespace

RgbTrainResult train_rgb_field(const RgbTrainOptions& o) {
  using namespace lrf::splat;
  const Stopwatch preparing;
  check_options(o);
  const auto lock = prepare_output_dir(o.out, o.force, o.resume);
  const SceneOptions& so = o.scene_options;
  Scene scene = load_scene(o.scene, so);
  if (scene.train_indices.empty()) fail(o.scene, "no training views");
  log_info("scene " + o.scene + " (" + scene.format + "): " + std::to_string(scene.train_indices.size()) +
           " training and " + std::to_string(scene.test_indices.size()) + " test views at " +
           std::to_string(scene.views.front().camera.width) + "x" + std::to_string(scene.views.front().camera.height) +
           ", " + std::to_string(scene.points.size()) + " SfM points" +
           (o.factor > 1 ? ", trained at 1/" + std::to_string(o.factor) + " of that size" : std::string()));

  TrainerOptions to = trainer_options(o);
  to.mip = o.mip;
  to.coarse_factor = o.coarse_factor;
  to.coarse_until = o.coarse_until < 0 ? to.schedule.until : o.coarse_until;
  const float bg = o.white_background ? 1.0f : 0.0f;
  to.background = torch::full({3}, bg);
  const double extent = scene.camera_extent();

  // config.json first: a folder being trained already says what it is.
  auto config = run_record(options_json(o));
  config.update(scene_config(o.scene, so, scene, o.out));
  config["space"] = field_kind_name(FieldKind::rgb);
  config["sh_degree"] = o.sh_degree;
  config["mip"] = o.mip;
  config["background"] = {bg, bg, bg};
  config["extent"] = extent;
  const Camera& first = scene.views[static_cast<size_t>(scene.train_indices.front())].camera;
  config["train_resolution"] = {first.width / o.factor, first.height / o.factor};
  config["schedule"] = {{"densify_from", to.schedule.from}, {"densify_until", to.schedule.until},
                        {"densify_every", to.schedule.interval},
                        {"opacity_reset_every", to.schedule.opacity_reset_every},
                        {"sh_degree_every", to.schedule.sh_degree_every}};
  if (to.coarse_factor > 1) config["coarse_phase"] = {{"factor", to.coarse_factor}, {"until_step", to.coarse_until}};
  const std::string config_path = (fs::path(o.out) / "config.json").string();
  write_json_file(config_path, config);

  nlohmann::json init_points;
  auto init = init_rgb_field(scene, o.sh_degree, o.seed, o.init_points, &init_points);
  config["init_points"] = init_points;
  write_json_file(config_path, config);
  log_info("initial field: " + std::to_string(init.size()) + " Gaussians from " +
           init_points.value("source", std::string("?")) + " points");
  // The views are decoded after config.json is written: a folder whose images fail to decode says what
  // it was meant to be, and a rerun takes it over (stopped_before_first_checkpoint).
  Trainer trainer(training_views(scene, o.factor), std::move(init), extent, to);
  RunOptions ro(o);
  ro.task = o.task;
  ro.prepared_seconds = preparing.seconds();
  const RunSummary summary = run_training(trainer, ro);

  config["result"] = {{"steps", summary.steps}, {"gaussians", summary.gaussians}, {"seconds", summary.seconds},
                      {"final_loss", summary.last_loss}, {"peak_memory_mb", peak_memory_mb()}};
  write_json_file(config_path, config);
  log_info("wrote " + o.out + "/point_cloud.ply: " + std::to_string(summary.gaussians) + " Gaussians after " +
           std::to_string(summary.steps) + " steps in " + Progress::format_duration(summary.seconds));
  return {summary.steps, summary.gaussians, summary.seconds};
}

RgbTrainOptions recorded_rgb_options(const std::string& out, const nlohmann::json& stored) {
  const std::string path = (fs::path(out) / "config.json").string();
  if (field_kind_of_config(stored, path) != FieldKind::rgb) fail(path, "not an RGB field");
  RgbTrainOptions o;
  o.out = out;
  try {
    const nlohmann::json& j = stored.at("options");
    o.scene = j.at("scene").get<std::string>();
    if (j.contains("images")) {
      o.scene_options.images_dir = j.at("images").get<std::string>();
      o.scene_options.downscale = j.at("downscale").get<int>();
      o.scene_options.test_every = j.at("test_every").get<int>();
      o.scene_options.train_views = j.value("train_views", 0);
      o.scene_options.test_list = j.at("test_list").get<std::string>();
      o.scene_options.format = j.at("format").get<std::string>();
      o.scene_options.crop_to_multiple_of_8 = j.at("crop8").get<bool>();
    } else {
      // Compare's rows before they were trained by this job recorded their scene only with the keys
      // that reload it.
      o.scene_options = splat::scene_options_from_config(stored, path);
    }
    o.factor = j.value("factor", 1);
    o.iters = j.at("iters").get<int64_t>();
    o.sh_degree = j.value("sh_degree", 3);
    o.mip = j.at("mip").get<bool>();
    o.seed = j.at("seed").get<uint64_t>();
    o.max_gaussians = j.value("max_gaussians", int64_t{0});
    o.densify_grad = j.value("densify_grad", splat::DensifyOptions{}.grad_threshold);
    o.checkpoint_every = j.value("checkpoint_every", int64_t{1000});
    o.sparse_adam = j.value("sparse_adam", false);
    o.white_background = j.value("white_background", false);
    o.coarse_factor = j.value("coarse_factor", 1);
    o.coarse_until = j.value("coarse_until", int64_t{-1});
    o.preset = j.value("preset", std::string("default"));
  } catch (const nlohmann::json::exception& e) {
    fail(path, std::string("cannot resume: missing or bad options: ") + e.what());
  }
  // Where the initial points came from: the resumed run builds the same starting field before its
  // checkpoint replaces it, and records the same origin.
  if (stored.contains("init_points") && stored["init_points"].is_object()) {
    const nlohmann::json& init = stored["init_points"];
    o.init_points.mode = init.value("mode", std::string("auto"));
    if (init.contains("far_shell")) {
      o.init_points.shell.points = init["far_shell"].value("lattice_points", 0);
      o.init_points.shell.radius_factor = init["far_shell"].value("radius_factor", 2.0);
    }
  }
  o.resume = true;
  return o;
}

}  // namespace lrf
