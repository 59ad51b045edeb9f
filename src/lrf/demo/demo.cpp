#include "lrf/demo/demo.h"

#include <filesystem>
#include <vector>

#include "lrf/autoencoder/resolve.h"
#include "lrf/camera_path/camera_path.h"
#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/run_info.h"
#include "lrf/field_kinds/field_type.h"
#include "lrf/frames/field_frames.h"
#include "lrf/pipeline/pipeline.h"
#include "lrf/scene/synthetic_scene.h"
#include "lrf/video/path_video.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {

// The scenes differ in their textures' phase and their camera rings (both follow the seed). The judged
// scene keeps seed 0, the synthetic scene the rest of lrf's tests and docs show.
struct DemoScene {
  const char* name;
  unsigned seed;
};
constexpr DemoScene kTrainScenes[] = {{"synthetic-a", 1}, {"synthetic-b", 2}};
constexpr DemoScene kJudgedScene = {"synthetic-held-out", 0};

std::string write_scene(const DemoOptions& o, const DemoScene& s) {
  const std::string dir = (fs::path(o.output) / "scenes" / s.name).string();
  SyntheticOptions synth = o.scenes;
  synth.seed = s.seed;
  log_info("demo: rendering the synthetic scene " + std::string(s.name) + " (" + std::to_string(synth.views) +
           " views, " + synth.size + ")");
  write_synthetic_scene(dir, synth);
  return dir;
}

void check_options(const DemoOptions& o) {
  if (o.scenes.views < 6)
    fail_usage("--views must be at least 6 (each scene keeps test views apart), got " + std::to_string(o.scenes.views));
  const PipelineOptions& p = o.pipeline;
  if (p.field_iters < 1 || p.stage1.steps < 1 || p.stage3.steps < 1 || p.refine.steps < 1)
    fail_usage("the demo's step counts must be at least 1");
  if (o.video.frames < 0) fail_usage("--video-frames must be 0 (no video) or more");
}

}  // namespace

DemoOptions::DemoOptions() {
  scenes.views = 24;
  scenes.size = "256x192";
  pipeline.max_side = 0;  // the scenes are small already
  pipeline.field_iters = 1500;
  pipeline.stage1.steps = 100;
  pipeline.stage1.batch.crop = 128;  // the synthetic views are 256x192: a crop that leaves room to move
  pipeline.stage3.steps = 100;
  pipeline.refine.steps = 300;
  video.frames = 48;
}

DemoResult run_demo(const DemoOptions& o) {
  check_options(o);
  if (fs::exists(o.output) && !fs::is_empty(o.output)) {
    if (!o.force) fail(o.output, "output folder exists and is not empty (use --force to replace it)");
    fs::remove_all(o.output);
  }
  try {
    resolve_autoencoder(o.pipeline.autoencoder);
  } catch (const Error& e) {
    fail(std::string(e.what()) + "\nThe demo needs the TAEF2 weights: run scripts/fetch-models.sh (or set "
         "LRF_MODELS to a folder holding taef2/taef2_encoder.pth and taef2_decoder.pth)");
  }
  fs::create_directories(o.output);
  write_json_file((fs::path(o.output) / "config.json").string(),
                  run_record({{"autoencoder", o.pipeline.autoencoder}, {"views", o.scenes.views},
                              {"size", o.scenes.size}, {"field_iters", o.pipeline.field_iters},
                              {"stage1_steps", o.pipeline.stage1.steps}, {"stage3_steps", o.pipeline.stage3.steps},
                              {"refine_steps", o.pipeline.refine.steps}, {"video_frames", o.video.frames}}));

  PipelineOptions p = o.pipeline;
  for (const auto& s : kTrainScenes) p.train_scenes.push_back(write_scene(o, s));
  p.eval_scenes = {write_scene(o, kJudgedScene)};
  p.out = (fs::path(o.output) / "pipeline").string();
  p.cache_dir = (fs::path(o.output) / "cache").string();
  log_info("demo: Stage I and Stage III learn from " + std::string(kTrainScenes[0].name) + " and " +
           kTrainScenes[1].name + "; every row is judged on the test views of " + kJudgedScene.name +
           ", which neither stage sees");

  DemoResult r;
  r.pipeline = run_pipeline(p);
  r.table_md = read_file(r.pipeline.at("table").get<std::string>());
  r.report_html = (fs::path(p.out) / "report.html").string();

  if (o.video.frames > 0) {
    // The paper's full method on the judged scene: the Stage I field refined through the Stage III decoder.
    const std::string field =
        (fs::path(p.out) / "fields" / (std::string(kJudgedScene.name) + "-ft-refined")).string();
    auto frames = open_field_frames(field);
    const auto path = camera_path::make_path(frames->scene(), camera_path::PathKind::orbit, o.video);
    video::PathVideoOptions vo;
    vo.video = (fs::path(o.output) / "video.mp4").string();
    vo.fps = 24;
    log_info("demo: an orbit video of the both+refine field (" + frames->describe() + ")");
    video::render_path_video(*frames, path, vo);
    r.video = vo.video;
  }
  return r;
}

}  // namespace lrf
