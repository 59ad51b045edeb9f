// lrf eval: PSNR, SSIM, MS-SSIM, FLIP and LPIPS of a trained field on the scene's test views, with its
// render speed and storage: the metrics.json that lrf compare writes for a method of the same kind.
#include <cstdio>
#include <filesystem>
#include <memory>

#include "command.h"
#include "lrf/latent/latent_run.h"
#include "lrf/nerf/nerf_run.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/rgb/rgb_eval.h"
#include "lrf/run/field_kind.h"
#include "lrf/splat/run/render_size.h"
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
  splat::check_render_options(o.scale, 0, 0);
  const auto kind = field_kind_of(o.out);
  if (kind == FieldKind::latent_nerf) return run_eval_latent(o, true);
  if (kind == FieldKind::latent) return run_eval_latent(o, false);
  if (!o.decoder.empty()) fail_usage("--decoder applies to latent fields and latent NeRFs");
  // The same scoring as lrf compare's RGB rows: one metrics.json, whichever command wrote it.
  RgbEvalOptions re;
  re.lpips_weights = o.lpips_weights;
  re.scale = o.scale;
  const nlohmann::json m = evaluate_rgb_run(o.out, re);
  nlohmann::json brief = {{"psnr", m["psnr"]}, {"ssim", m["ssim"]}, {"ms_ssim", m["ms_ssim"]}, {"flip", m["flip"]},
                          {"lpips", m["lpips"]}, {"render_fps", m["render_fps"]}, {"views", m["views"].size()}};
  std::printf("%s\n", brief.dump().c_str());
  log_info("wrote " + (fs::path(o.out) / "metrics.json").string() + " and the rendered test views in " +
           (fs::path(o.out) / "eval").string());
  return 0;
}

lrf::cli::CommandRegistration reg(22, [](CLI::App& root) {
  auto* cmd = root.add_subcommand("eval", "Score a trained field on the test views (writes OUT/metrics.json and "
                                           "the rendered views in OUT/eval); latent fields and latent NeRFs are "
                                           "decoded first");
  auto o = std::make_shared<EvalOptions>();
  cmd->add_option("out", o->out, "Output folder of lrf train, lrf refine or one method's folder of lrf compare")->required();
  cmd->add_option("--scale", o->scale, "Evaluate at this multiple of the training resolution")->capture_default_str();
  cmd->add_option("--decoder", o->decoder, "Latent fields (and latent NeRFs): decode with these decoder weights (e.g. Stage III's; default: "
                  "the decoder a refined field was fitted through, else the autoencoder's)");
  cmd->add_option("--lpips-weights", o->lpips_weights,
                  "LPIPS (VGG, lpips v0.1 layout: net.slice*/lin* keys) weights file; without it "
                  "metrics.json has \"lpips\": null and the reason");
  lrf::cli::add_scene_override_option(cmd);
  lrf::cli::on_run(cmd, [o] { return run_eval(*o); });
});

}  // namespace
