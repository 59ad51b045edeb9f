// lrf demo: the whole method in miniature on built-in synthetic scenes (src/lrf/demo/demo.h).
#include <cstdio>
#include <memory>

#include "autoencoder_option.h"
#include "command.h"
#include "lrf/core/log.h"
#include "lrf/demo/demo.h"

namespace {

lrf::cli::CommandRegistration reg(1, [](CLI::App& root) {
  auto* demo = root.add_subcommand(
      "demo", "Built-in demo of the whole method in miniature: Stage I and III learn from two synthetic scenes, a "
              "third is judged (rgb/8 baselines, stock/encoder/decoder/both latent rows, both refined), with the "
              "ablation table, report.html and a short video");
  auto o = std::make_shared<lrf::DemoOptions>();
  demo->add_option("-o,--output", o->output, "Output folder")->capture_default_str();
  lrf::cli::add_autoencoder_option(demo, &o->pipeline.autoencoder, "of the latent fields");
  demo->add_option("--views", o->scenes.views, "Views per synthetic scene")->capture_default_str();
  demo->add_option("--size", o->scenes.size, "Size of the synthetic views, WxH (latent fields are 8x smaller)")->capture_default_str();
  demo->add_option("--field-steps,--iters", o->pipeline.field_iters, "Training steps per field (latent fields and RGB baselines)")
      ->capture_default_str();
  demo->add_option("--stage1-steps", o->pipeline.stage1.steps, "Stage I (encoder fine-tuning) steps")->capture_default_str();
  demo->add_option("--stage3-steps", o->pipeline.stage3.steps, "Stage III (decoder fine-tuning) steps")->capture_default_str();
  demo->add_option("--refine-steps", o->pipeline.refine.steps, "Steps of each refined row")->capture_default_str();
  demo->add_option("--video-frames", o->video.frames, "Frames of the orbit video of the both+refine field (0: none)")
      ->capture_default_str();
  demo->add_flag("--force", o->force, "Replace the output folder if it exists");
  lrf::cli::on_run(demo, [o] {
    const lrf::DemoResult r = lrf::run_demo(*o);
    std::printf("%s", r.table_md.c_str());
    if (!r.video.empty()) lrf::log_info("demo: wrote " + r.video);
    lrf::log_info("demo: done; open " + r.report_html + " in a browser");
    return 0;
  });
});

}  // namespace
