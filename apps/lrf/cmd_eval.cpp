// lrf eval: PSNR, SSIM, MS-SSIM and FLIP of a trained field on the scene's test views.
#include <filesystem>
#include <memory>

#include "command.h"
#include "lrf/latent/latent_run.h"
#include "lrf/nerf/nerf_run.h"
#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/core/log.h"
#include "lrf/core/progress.h"
#include "lrf/core/run_info.h"
#include "lrf/eval/scores.h"
#include "lrf/splat/run/render_size.h"
#include "lrf/splat/run/run_folder.h"
#include "lrf/rgb/rgb_field.h"
#include "scene_override_option.h"

namespace fs = std::filesystem;

namespace {

struct EvalOptions {
  std::string out;
  double scale = 1.0;
  std::string decoder;
  std::string lpips_weights;
};

int run_eval_latent(const EvalOptions& o, bool nerf) {
  if (o.scale != 1.0) lrf::fail_usage("--scale applies to RGB fields; latent fields are scored at 8x their latent size");
  lrf::LatentEvalOptions le;
  le.decoder = o.decoder;
  le.lpips_weights = o.lpips_weights;
  auto m = nerf ? lrf::nerf::evaluate_nerf_run(o.out, le) : lrf::evaluate_latent_run(o.out, le);
  nlohmann::json brief = {{"psnr", m["psnr"]}, {"ssim", m["ssim"]}, {"ms_ssim", m["ms_ssim"]}, {"flip", m["flip"]},
                          {"lpips", m["lpips"]},
                          {"roundtrip_psnr", m["roundtrip_psnr"]}, {"latent_psnr", m["latent_psnr"]},
                          {"views", m["views"].size()}};
  std::printf("%s\n", brief.dump().c_str());
  lrf::log_info("wrote " + (fs::path(o.out) / "metrics.json").string());
  return 0;
}

int run_eval(const EvalOptions& o) {
  using namespace lrf;
  using namespace lrf::splat;
  check_render_options(o.scale, 0, 0);
  if (nerf::is_nerf_run(o.out)) return run_eval_latent(o, true);
  if (is_latent_run(o.out)) return run_eval_latent(o, false);
  if (!o.decoder.empty() || !o.lpips_weights.empty()) fail_usage("--decoder and --lpips-weights apply to latent fields");
  auto run = open_field_run(o.out);
  if (run.scene.test_indices.empty()) fail(o.out, "the scene has no test views");
  nlohmann::json views = nlohmann::json::array();
  std::vector<ImageScores> scores;
  Progress progress("eval", static_cast<long>(run.scene.test_indices.size()));
  long done = 0;
  int width = 0, height = 0;
  for (int i : run.scene.test_indices) {
    const auto& view = run.scene.views[static_cast<size_t>(i)];
    auto camera = scaled_camera(view.camera, o.scale, 0, 0);
    width = camera.width;
    height = camera.height;
    auto image = render_field(run.field, camera, run.render).image.clamp(0, 1);
    cv::Mat truth = run.scene.load_image(i);
    if (truth.cols != camera.width || truth.rows != camera.height)
      truth = resize_area(truth, camera.width, camera.height);
    const ImageScores s = score_image(image_to_tensor(truth), image, nullptr, view.name);
    scores.push_back(s);
    auto j = scores_json(s);
    j["name"] = view.name;
    views.push_back(j);
    progress.update(++done, {{"psnr", s.psnr}, {"ssim", s.ssim}});
  }
  const ImageScores mean = mean_scores(scores);
  nlohmann::json metrics = scores_json(mean);
  metrics["views"] = views;
  metrics["resolution"] = {width, height};
  metrics["scale"] = o.scale;
  metrics["gaussians"] = run.field.size();
  metrics["run"] = run_record({{"out", o.out}, {"scale", o.scale}});
  const std::string path = (fs::path(o.out) / "metrics.json").string();
  write_json_file(path, metrics);
  progress.finish({{"psnr", mean.psnr}, {"ssim", mean.ssim}});
  nlohmann::json brief = scores_json(mean);
  brief.erase("lpips");
  brief["views"] = views.size();
  std::printf("%s\n", brief.dump().c_str());
  log_info("wrote " + path);
  return 0;
}

lrf::cli::CommandRegistration reg(22, [](CLI::App& root) {
  auto* cmd = root.add_subcommand("eval", "Score a trained field on the test views (writes OUT/metrics.json); latent fields are decoded first");
  auto o = std::make_shared<EvalOptions>();
  cmd->add_option("out", o->out, "Output folder of lrf train")->required();
  cmd->add_option("--scale", o->scale, "Evaluate at this multiple of the training resolution")->capture_default_str();
  cmd->add_option("--decoder", o->decoder, "Latent fields (and latent NeRFs): decode with these decoder weights (e.g. Stage III's; default: "
                  "the decoder a refined field was fitted through, else the autoencoder's)");
  cmd->add_option("--lpips-weights", o->lpips_weights,
                  "Latent fields: LPIPS (VGG, lpips v0.1 layout: net.slice*/lin* keys) weights file; without it "
                  "metrics.json has \"lpips\": null and the reason");
  lrf::cli::add_scene_override_option(cmd);
  lrf::cli::on_run(cmd, [o] { return run_eval(*o); });
});

}  // namespace
