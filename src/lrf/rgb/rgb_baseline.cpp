#include "lrf/rgb/rgb_baseline.h"

#include <filesystem>

#include <torch/torch.h>

#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/core/progress.h"
#include "lrf/core/resources.h"
#include "lrf/core/run_info.h"
#include "lrf/rgb/rgb_field.h"
#include "lrf/splat/run/run_folder.h"
#include "lrf/splat/run/train_run.h"

namespace fs = std::filesystem;

namespace lrf {

void train_rgb_baseline(const RgbBaselineOptions& o) {
  using namespace lrf::splat;
  if (o.factor < 1) fail("rgb baseline: the downscale factor must be at least 1");
  const std::string& scene_root = o.scene;
  const std::string& out = o.out;
  const int64_t iters = o.iters;
  const bool mip = o.mip;
  const uint64_t seed = o.seed;
  SceneOptions so = o.scene_options;
  so.crop_to_multiple_of_8 = true;
  Scene scene = load_scene(scene_root, so);
  const auto lock = prepare_output_dir(out, true, o.resume);
  std::vector<TrainView> views;
  for (int i : scene.train_indices) {
    const View& v = scene.views[static_cast<size_t>(i)];
    // The views are cropped to multiples of 8, so any factor up to 8 that divides them keeps the intrinsics exact.
    if (v.camera.width % o.factor || v.camera.height % o.factor)
      fail(v.image_path, "the view's size is not a multiple of the downscale factor " + std::to_string(o.factor));
    Camera cam = v.camera.resized(v.camera.width / o.factor, v.camera.height / o.factor);
    cv::Mat image = scene.load_image(i);
    if (o.factor != 1) image = resize_area(image, cam.width, cam.height);
    views.push_back({v.name, cam, splat::image_to_tensor(image)});
  }
  TrainerOptions to;
  to.iterations = iters;
  to.sh_degree = 3;
  to.mip = mip;
  to.seed = seed;
  to.schedule = DensifySchedule::for_iterations(iters);
  to.background = torch::zeros({3});
  const double extent = scene.camera_extent();
  auto config = run_record({{"scene", scene_root}, {"iters", iters}, {"mip", mip}, {"seed", seed}, {"factor", o.factor}});
  config.update(scene_config(scene_root, so, scene, out));
  config["space"] = "rgb";
  config["sh_degree"] = 3;
  config["mip"] = mip;
  config["background"] = {0.0f, 0.0f, 0.0f};
  config["extent"] = extent;
  config["train_resolution"] = {views.front().camera.width, views.front().camera.height};
  const std::string config_path = (fs::path(out) / "config.json").string();
  write_json_file(config_path, config);
  nlohmann::json init_points;
  auto init = init_rgb_field(scene, 3, seed, o.init_points, &init_points);
  config["init_points"] = init_points;
  write_json_file(config_path, config);
  Trainer trainer(std::move(views), std::move(init), extent, to);
  RunOptions ro;
  ro.out = out;
  ro.resume = o.resume;
  ro.task = std::string("train-rgb") + (o.factor == 1 ? "" : "/" + std::to_string(o.factor)) + (mip ? "-mip" : "");
  auto summary = run_training(trainer, ro);
  config["result"] = {{"steps", summary.steps}, {"gaussians", summary.gaussians}, {"seconds", summary.seconds},
                      {"peak_memory_mb", peak_memory_mb()}};
  write_json_file(config_path, config);
}

}  // namespace lrf
