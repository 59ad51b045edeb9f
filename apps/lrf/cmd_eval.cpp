// lrf eval: PSNR, SSIM, MS-SSIM, FLIP and LPIPS of a trained field on the scene's test views, with its
// render speed and storage: the metrics.json that lrf compare writes for a method of the same kind.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "command.h"
#include "detail_options.h"
#include "next_steps.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/run_info.h"
#include "lrf/detail/detail_eval.h"
#include "lrf/field_kinds/field_type.h"
#include "lrf/splat/run/render_size.h"
#include "scene_override_option.h"

namespace fs = std::filesystem;

namespace {

struct EvalOptions {
  std::string out;
  lrf::detail::DetailEvalOptions scoring;  // decoder, LPIPS weights, scale; and the detail pass's options
  bool json = false;
  bool detail = false;
};

// "0.542" for a number, "-" for null (a metric that could not be computed).
std::string value(const nlohmann::json& v, const char* format) {
  if (!v.is_number()) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, format, v.get<double>());
  return buf;
}

// The scores as a person reads them: each metric with its unit and which way is better, and for a latent
// field the ceiling its autoencoder sets (the round trip of the same views), then where the files went.
void print_summary(const EvalOptions& o, const nlohmann::json& brief, bool latent) {
  std::printf("%s: %zu test views\n", o.out.c_str(), static_cast<size_t>(brief["views"].get<int64_t>()));
  std::printf("  PSNR     %8s dB   higher is better", value(brief["psnr"], "%.2f").c_str());
  if (latent) {
    std::printf(" (the autoencoder's own round trip of these views: %s dB)",
                value(brief["roundtrip_psnr"], "%.2f").c_str());
  }
  std::printf("\n  SSIM     %8s      higher is better (1: identical)\n", value(brief["ssim"], "%.3f").c_str());
  std::printf("  MS-SSIM  %8s      higher is better%s\n", value(brief["ms_ssim"], "%.3f").c_str(),
              brief["ms_ssim"].is_null() ? " (the views are too small for its five scales)" : "");
  std::printf("  FLIP     %8s      lower is better (0: identical)\n", value(brief["flip"], "%.3f").c_str());
  std::printf("  LPIPS    %8s      lower is better%s\n", value(brief["lpips"], "%.3f").c_str(),
              brief["lpips"].is_null() ? " (not computed: give --lpips-weights)" : "");
  if (brief.contains("render_fps")) std::printf("  render   %8s frames/s\n", value(brief["render_fps"], "%.1f").c_str());
}

void report(const EvalOptions& o, const nlohmann::json& brief, bool latent) {
  if (o.json) {
    std::printf("%s\n", brief.dump().c_str());
  } else {
    print_summary(o, brief, latent);
  }
  std::fflush(stdout);
  lrf::log_info("wrote " + (fs::path(o.out) / "metrics.json").string() + " (every view's scores) and the rendered test views in " +
                (fs::path(o.out) / "eval").string());
  lrf::cli::log_next_steps(o.out, "scored");
}

// The field's test views with the detail pass, scored frame by frame into OUT/detail/ (metrics.json and
// eval/*.png) so that the field's own metrics.json stays as it was.
int run_eval_detail(const EvalOptions& o) {
  using namespace lrf;
  const std::string dir = (fs::path(o.out) / "detail").string();
  const nlohmann::json m = lrf::detail::evaluate_with_detail(o.out, dir, o.scoring);
  nlohmann::json brief = {{"psnr", m["psnr"]}, {"ssim", m["ssim"]}, {"ms_ssim", m["ms_ssim"]}, {"flip", m["flip"]},
                          {"lpips", m["lpips"]}, {"frame_fps", m["frame_fps"]}, {"detail_ms", m["detail_ms"]},
                          {"views", m["views"].size()}};
  EvalOptions shown = o;
  shown.out = dir;
  report(shown, brief, false);
  return 0;
}

// A run writes "result" into its config.json when it finishes; before that its folder holds the Gaussians of
// its last checkpoint, which score well below the finished field. Said once, since the figures look final.
void warn_if_unfinished(const std::string& run) {
  const std::string config_path = (fs::path(run) / "config.json").string();
  if (!fs::exists(config_path)) return;  // the kind lookup names the missing file
  const nlohmann::json config = lrf::read_json_file(config_path);
  if (config.is_object() && !config.contains("result")) {
    lrf::log_warn(run + " has not finished (its config.json has no result): these are the scores of its last "
                  "checkpoint. Finish it first (the same command with --resume) for the field's own figures");
  }
}

int run_eval(const EvalOptions& o) {
  using namespace lrf;
  warn_if_unfinished(o.out);
  if (o.detail) return run_eval_detail(o);
  splat::check_render_options(o.scoring.scale, 0, 0);
  // The same scoring as lrf compare's rows: one metrics.json, whichever command wrote it.
  const FieldType& type = field_type_of(o.out);
  nlohmann::json m = type.evaluate(o.out, o.scoring);
  nlohmann::json brief = {{"psnr", m["psnr"]}, {"ssim", m["ssim"]}, {"ms_ssim", m["ms_ssim"]}, {"flip", m["flip"]},
                          {"lpips", m["lpips"]}};
  // A decoded field's ceiling is its autoencoder's round trip; an RGB field's speed is its own render's.
  if (type.decoded()) {
    brief["roundtrip_psnr"] = m["roundtrip_psnr"];
    brief["latent_psnr"] = m["latent_psnr"];
  } else {
    brief["render_fps"] = m["render_fps"];
  }
  brief["views"] = m["views"].size();
  report(o, brief, type.decoded());
  return 0;
}

lrf::cli::CommandRegistration reg(22, [](CLI::App& root) {
  auto* cmd = root.add_subcommand("eval", "Score a trained field on the test views (writes OUT/metrics.json and "
                                           "the rendered views in OUT/eval); latent fields and latent NeRFs are "
                                           "decoded first");
  auto o = std::make_shared<EvalOptions>();
  cmd->add_option("out", o->out, "Output folder of lrf train, lrf refine or one method's folder of lrf compare")->required();
  cmd->add_option("--scale", o->scoring.scale, "Evaluate at this multiple of the training resolution")->capture_default_str();
  cmd->add_option("--decoder", o->scoring.decoder, "Latent fields (and latent NeRFs): decode with these decoder weights (e.g. Stage III's; default: "
                  "the decoder a refined field was fitted through, else the autoencoder's)");
  cmd->add_option("--lpips-weights", o->scoring.lpips_weights,
                  "LPIPS (VGG, lpips v0.1 layout: net.slice*/lin* keys) weights file; without it "
                  "metrics.json has \"lpips\": null and the reason");
  cmd->add_flag("--json", o->json,
                "Print the scores as one JSON line (psnr, ssim, ms_ssim, flip, lpips, views; roundtrip_psnr and "
                "latent_psnr for latent fields, render_fps for RGB ones) instead of the summary");
  cmd->add_flag("--detail", o->detail,
                "Score the field with the detail pass (training photographs carried into each test view with the "
                "field's depth and blended in where they agree), into OUT/detail/ (splat fields)");
  lrf::cli::add_detail_options(cmd, &o->scoring.detail);
  lrf::cli::add_scene_override_option(cmd);
  lrf::cli::on_run(cmd, [o] { return run_eval(*o); });
});

}  // namespace
