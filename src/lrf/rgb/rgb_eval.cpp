#include "lrf/rgb/rgb_eval.h"

#include <algorithm>
#include <filesystem>
#include <optional>

#include <torch/torch.h>

#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/core/progress.h"
#include "lrf/core/resources.h"
#include "lrf/core/run_info.h"
#include "lrf/core/state_dict.h"
#include "lrf/eval/lpips.h"
#include "lrf/eval/scores.h"
#include "lrf/rgb/rgb_field.h"
#include "lrf/splat/render_field.h"
#include "lrf/splat/run/render_size.h"
#include "lrf/splat/run/run_folder.h"

namespace fs = std::filesystem;

namespace lrf {

nlohmann::json evaluate_rgb_run(const std::string& out, const RgbEvalOptions& o) {
  using namespace lrf::splat;
  check_render_options(o.scale, 0, 0);  // before the field is even opened
  FieldRun run = open_field_run(out);
  if (run.scene.test_indices.empty()) fail(out, "the scene has no test views");
  std::optional<Lpips> lpips;
  if (!o.lpips_weights.empty())
    lpips = Lpips::from_state_dict(tensor_map(load_state_dict(o.lpips_weights)), o.lpips_weights);
  // Every view's size is checked before anything is written.
  std::vector<Camera> cameras;
  for (int i : run.scene.test_indices)
    cameras.push_back(scaled_camera(run.scene.views[static_cast<size_t>(i)].camera, o.scale, 0, 0));
  const std::string image_dir = (fs::path(out) / "eval").string();
  fs::create_directories(image_dir);
  std::vector<ImageScores> scores;
  nlohmann::json views = nlohmann::json::array();
  double render_seconds = 0;
  Progress progress("eval", static_cast<long>(cameras.size()));
  for (size_t k = 0; k < cameras.size(); ++k) {
    const int i = run.scene.test_indices[k];
    const View& v = run.scene.views[static_cast<size_t>(i)];
    const Camera& camera = cameras[k];
    Stopwatch clock;
    auto image = render_field(run.field, camera, run.render).image.clamp(0, 1);
    render_seconds += clock.seconds();
    cv::Mat rendered = splat::tensor_to_image(image);
    cv::Mat truth = run.scene.load_image(i);
    if (truth.cols != camera.width || truth.rows != camera.height)
      truth = resize_area(truth, camera.width, camera.height);
    const ImageScores s = score_image(truth, rendered, lpips ? &*lpips : nullptr, v.name);
    scores.push_back(s);
    auto j = scores_json(s);
    j["name"] = v.name;
    views.push_back(j);
    write_image_rgb((fs::path(image_dir) / (fs::path(v.name).stem().string() + ".png")).string(), rendered);
    progress.update(static_cast<long>(k + 1), {{"psnr", s.psnr}, {"ssim", s.ssim}});
  }
  const ImageScores mean = mean_scores(scores);
  progress.finish({{"psnr", mean.psnr}, {"ssim", mean.ssim}});
  nlohmann::json metrics = scores_json(mean);
  if (!lpips) metrics["lpips_reason"] = "no --lpips-weights given";
  metrics["views"] = views;
  metrics["resolution"] = {cameras.front().width, cameras.front().height};
  metrics["scale"] = o.scale;
  metrics["gaussians"] = run.field.size();
  metrics["render_fps"] = double(scores.size()) / std::max(render_seconds, 1e-9);
  std::error_code ec;
  metrics["storage_mb"] = double(fs::file_size(fs::path(out) / "point_cloud.ply", ec)) / (1 << 20);
  if (run.config.contains("result")) {
    metrics["train_seconds"] = run.config["result"].value("seconds", 0.0);
    metrics["peak_memory_mb"] = run.config["result"].value("peak_memory_mb", 0.0);
  }
  metrics["run"] = run_record({{"out", out}, {"scale", o.scale}, {"lpips_weights", o.lpips_weights}});
  write_json_file((fs::path(out) / "metrics.json").string(), metrics);
  return metrics;
}

}  // namespace lrf
