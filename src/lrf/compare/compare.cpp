#include "lrf/compare/compare.h"

#include <filesystem>

#include <torch/torch.h>

#include "lrf/autoencoder/image_tensor.h"
#include "lrf/core/error.h"
#include "lrf/core/folder_lock.h"
#include "lrf/core/image_io.h"
#include "lrf/core/log.h"
#include "lrf/core/progress.h"
#include "lrf/core/resources.h"
#include "lrf/core/run_info.h"
#include "lrf/core/state_dict.h"
#include "lrf/eval/lpips.h"
#include "lrf/eval/report.h"
#include "lrf/eval/scores.h"
#include "lrf/eval/table.h"
#include "lrf/latent/latent_field.h"
#include "lrf/latent/latent_run.h"
#include "lrf/splat/run/run_folder.h"
#include "lrf/splat/render_field.h"
#include "lrf/rgb/rgb_field.h"
#include "lrf/splat/run/train_run.h"

namespace fs = std::filesystem;

namespace lrf {

void train_rgb_at_latent_resolution(const std::string& scene_root, const SceneOptions& so_in, const std::string& out,
                                    int64_t iters, bool mip, uint64_t seed, bool resume) {
  using namespace lrf::splat;
  SceneOptions so = so_in;
  so.crop_to_multiple_of_8 = true;
  Scene scene = load_scene(scene_root, so);
  const auto lock = prepare_output_dir(out, true, resume);
  std::vector<TrainView> views;
  for (int i : scene.train_indices) {
    const View& v = scene.views[static_cast<size_t>(i)];
    Camera cam = latent_camera(v.camera);
    views.push_back({v.name, cam, splat::image_to_tensor(resize_area(scene.load_image(i), cam.width, cam.height))});
  }
  TrainerOptions to;
  to.iterations = iters;
  to.sh_degree = 3;
  to.mip = mip;
  to.seed = seed;
  to.schedule = DensifySchedule::for_iterations(iters);
  to.background = torch::zeros({3});
  const double extent = scene.camera_extent();
  auto config = run_record({{"scene", scene_root}, {"iters", iters}, {"mip", mip}, {"seed", seed}});
  config.update(scene_config(scene_root, so, scene));
  config["space"] = "rgb";
  config["sh_degree"] = 3;
  config["mip"] = mip;
  config["background"] = {0.0f, 0.0f, 0.0f};
  config["extent"] = extent;
  config["train_resolution"] = {views.front().camera.width, views.front().camera.height};
  const std::string config_path = (fs::path(out) / "config.json").string();
  write_json_file(config_path, config);
  Trainer trainer(std::move(views), init_rgb_field(scene, 3, seed), extent, to);
  RunOptions ro;
  ro.out = out;
  ro.resume = resume;
  ro.task = mip ? "train-rgb/8-mip" : "train-rgb/8";
  auto summary = run_training(trainer, ro);
  config["result"] = {{"steps", summary.steps}, {"gaussians", summary.gaussians}, {"seconds", summary.seconds},
                      {"peak_memory_mb", peak_memory_mb()}};
  write_json_file(config_path, config);
}

nlohmann::json evaluate_rgb_run(const std::string& out, const std::string& lpips_weights) {
  using namespace lrf::splat;
  FieldRun run = open_field_run(out);
  if (run.scene.test_indices.empty()) fail(out, "the scene has no test views");
  std::optional<Lpips> lpips;
  if (!lpips_weights.empty()) lpips = Lpips::from_state_dict(tensor_map(load_state_dict(lpips_weights)), lpips_weights);
  const std::string image_dir = (fs::path(out) / "eval").string();
  fs::create_directories(image_dir);
  std::vector<ImageScores> scores;
  nlohmann::json views = nlohmann::json::array();
  double render_seconds = 0;
  for (int i : run.scene.test_indices) {
    const View& v = run.scene.views[static_cast<size_t>(i)];
    Stopwatch clock;
    auto image = render_field(run.field, v.camera, run.render).image.clamp(0, 1);
    render_seconds += clock.seconds();
    cv::Mat rendered = splat::tensor_to_image(image);
    ImageScores s = score_image(run.scene.load_image(i), rendered, lpips ? &*lpips : nullptr, v.name);
    scores.push_back(s);
    auto j = scores_json(s);
    j["name"] = v.name;
    views.push_back(j);
    write_image_rgb((fs::path(image_dir) / (fs::path(v.name).stem().string() + ".png")).string(), rendered);
  }
  nlohmann::json metrics = scores_json(mean_scores(scores));
  if (!lpips) metrics["lpips_reason"] = "no --lpips-weights given";
  metrics["views"] = views;
  metrics["resolution"] = {run.scene.views[0].camera.width, run.scene.views[0].camera.height};
  metrics["gaussians"] = run.field.size();
  metrics["render_fps"] = double(scores.size()) / std::max(render_seconds, 1e-9);
  std::error_code ec;
  metrics["storage_mb"] = double(fs::file_size(fs::path(out) / "point_cloud.ply", ec)) / (1 << 20);
  if (run.config.contains("result")) {
    metrics["train_seconds"] = run.config["result"].value("seconds", 0.0);
    metrics["peak_memory_mb"] = run.config["result"].value("peak_memory_mb", 0.0);
  }
  metrics["run"] = run_record({{"out", out}, {"lpips_weights", lpips_weights}});
  write_json_file((fs::path(out) / "metrics.json").string(), metrics);
  return metrics;
}

namespace {

std::string method_dir(const std::string& method) {
  std::string d = method;
  for (auto& c : d)
    if (c == '/') c = '_';
  return d;
}

}  // namespace

nlohmann::json run_compare(const CompareOptions& o) {
  for (const auto& m : o.methods) {
    if (m != "rgb/8" && m != "rgb/8-mip" && m != "latent") fail("unknown method '" + m + "' (rgb/8, rgb/8-mip, latent)");
  }
  fs::create_directories(o.out);
  const FolderLock lock(o.out);  // each method's folder below is locked again by its own training job
  SceneOptions so;
  so.images_dir = o.images;
  so.downscale = o.downscale;
  so.test_every = o.test_every;
  so.crop_to_multiple_of_8 = true;
  Scene scene = load_scene(o.scene, so);
  nlohmann::json all = nlohmann::json::object();
  for (const auto& method : o.methods) {
    const std::string dir = (fs::path(o.out) / method_dir(method)).string();
    const std::string metrics_path = (fs::path(dir) / "metrics.json").string();
    if (!o.force && fs::exists(metrics_path)) {
      log_info(method + ": reusing " + metrics_path + " (pass --force to recompute)");
      all[method] = read_json_file(metrics_path);
      continue;
    }
    const bool resume = !o.force && fs::exists(splat::checkpoint_path(dir)) && !fs::exists(fs::path(dir) / "point_cloud.ply");
    log_info("== " + method + (resume ? " (resuming)" : ""));
    if (method == "latent") {
      if (o.force || !fs::exists(fs::path(dir) / "point_cloud.ply")) {
        LatentTrainOptions l;
        l.scene = o.scene;
        l.out = dir;
        l.images = o.images;
        l.downscale = o.downscale;
        l.test_every = o.test_every;
        l.autoencoder = o.autoencoder;
        l.encoder = o.encoder;
        l.cache_dir = o.cache_dir;
        l.sh_degree = o.latent_sh_degree;
        l.iters = o.latent_iters > 0 ? o.latent_iters : o.iters;
        l.seed = o.seed;
        l.resume = resume;
        l.force = !resume;
        train_latent_field(l);
      }
      LatentEvalOptions le;
      le.decoder = o.decoder;
      le.lpips_weights = o.lpips_weights;
      all[method] = evaluate_latent_run(dir, le);
    } else {
      if (o.force || !fs::exists(fs::path(dir) / "point_cloud.ply")) {
        train_rgb_at_latent_resolution(o.scene, so, dir, o.iters, method == "rgb/8-mip", o.seed, resume);
      }
      all[method] = evaluate_rgb_run(dir, o.lpips_weights);
    }
  }

  const std::vector<std::string> header = {"method", "psnr", "ssim", "lpips", "train_seconds", "gaussians",
                                           "storage_mb", "render_fps", "decode_fps", "peak_memory_mb"};
  std::vector<Row> rows;
  for (const auto& method : o.methods) {
    const auto& m = all[method];
    Row row = {method};
    for (size_t k = 1; k < header.size(); ++k) row.push_back(Cell::number_in(m, header[k].c_str()));
    rows.push_back(std::move(row));
  }
  write_table_csv((fs::path(o.out) / "table.csv").string(), header, rows);
  write_table_markdown((fs::path(o.out) / "table.md").string(), header, rows);

  ReportSpec spec;
  spec.title = "lrf compare: " + fs::path(o.scene).filename().string();
  spec.summary_header = header;
  spec.summary_rows = rows;
  spec.summary_better = {Better::none,  Better::higher, Better::higher, Better::lower, Better::lower,
                         Better::none,  Better::lower,  Better::higher, Better::higher, Better::lower};
  const Camera& c0 = scene.views[0].camera;
  spec.notes.push_back("Scene " + o.scene + ", test views every " + std::to_string(o.test_every) + "th, scored at " +
                       std::to_string(c0.width) + "x" + std::to_string(c0.height) + " (latent " +
                       std::to_string(c0.width / 8) + "x" + std::to_string(c0.height / 8) + "). rgb/8 and rgb/8-mip: RGB "
                       "3D Gaussian splatting trained on the views downscaled 8x and rendered at full resolution "
                       "(the paper's 3DGS/8 and Mip-Splatting/8); latent: a latent field with the " +
                       o.autoencoder + " autoencoder, decoded (the paper's 3DGS-VAE). " + std::to_string(o.iters) +
                       " iterations.");
  if (!all.empty() && all.begin()->value("lpips", nlohmann::json()).is_null())
    spec.notes.push_back("LPIPS not computed: pass --lpips-weights with the lpips v0.1 VGG weights.");
  spec.max_image_side = 640;
  for (int i : scene.test_indices) {
    const View& v = scene.views[static_cast<size_t>(i)];
    ReportView rv;
    rv.name = v.name;
    rv.ground_truth = {"ground truth", scene.load_image(i), {}};
    for (const auto& method : o.methods) {
      const std::string png =
          (fs::path(o.out) / method_dir(method) / "eval" / (fs::path(v.name).stem().string() + ".png")).string();
      ReportImage im{method, fs::exists(png) ? read_image_rgb(png) : cv::Mat(), {}};
      for (const auto& vj : all[method]["views"]) {
        if (vj.value("name", std::string()) == v.name) {
          im.numbers = {{"PSNR", Cell::number_in(vj, "psnr")},
                        {"SSIM", Cell::number_in(vj, "ssim")},
                        {"LPIPS", Cell::number_in(vj, "lpips")}};
        }
      }
      rv.methods.push_back(im);
    }
    spec.views.push_back(rv);
  }
  write_html_report((fs::path(o.out) / "report.html").string(), spec);
  nlohmann::json summary = {{"methods", all}, {"run", run_record({{"scene", o.scene}, {"iters", o.iters}})}};
  write_json_file((fs::path(o.out) / "compare.json").string(), summary);
  return summary;
}

}  // namespace lrf
