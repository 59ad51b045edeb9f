#include "lrf/pipeline/pipeline_jobs.h"

namespace lrf {
namespace {

std::vector<RgbBaseline> rgb_baselines(const PipelineOptions& o) {
  static const std::vector<RgbBaseline> all = {{"rgb/8", "rgb8", 8, false}, {"rgb/8-mip", "rgb8mip", 8, true},
                                               {"rgb", "rgb", 1, false},     {"rgb-mip", "rgbmip", 1, true}};
  std::vector<RgbBaseline> used;
  if (!o.rgb_baseline) return used;
  for (const RgbBaseline& b : all)
    if (b.factor > 1 || o.rgb_full) used.push_back(b);
  return used;
}

}  // namespace

PipelineJobs pipeline_jobs(const PipelineOptions& o, const PipelineScenes& scenes, const PipelinePaths& paths) {
  PipelineJobs jobs;
  EncoderFinetuneOptions& e = jobs.stage1;
  e = o.stage1;
  e.scenes = scenes.train;
  e.scene_resolutions.clear();
  if (scenes.any_given(scenes.train)) {
    for (const auto& s : scenes.train) e.scene_resolutions.push_back(scenes.given.at(s));
  }
  e.correspondence_files.clear();
  e.autoencoder = o.autoencoder;
  e.encoder.clear();
  e.out = paths.encoder();
  e.max_side = o.max_side;
  e.seed = o.seed;

  jobs.stage3 = o.stage3;
  jobs.stage3.autoencoder = o.autoencoder;
  jobs.stage3.seed = o.seed;

  LatentTrainOptions& l = jobs.latent_field;
  l.autoencoder = o.autoencoder;
  l.cache_dir = o.cache_dir;
  l.iters = o.field_iters;
  l.seed = o.seed;

  RgbTrainOptions& b = jobs.rgb_field;
  b.scene_options.train_views = o.eval_train_views;
  b.scene_options.crop_to_multiple_of_8 = true;  // the latent fields' views
  b.iters = o.field_iters;
  b.seed = o.seed;
  jobs.baselines = rgb_baselines(o);

  jobs.refine = o.refine;
  jobs.refine.seed = o.seed;
  jobs.refine.cache_dir = o.cache_dir;

  jobs.scoring.lpips_weights = o.lpips_weights;
  jobs.scoring.detail = o.detail;
  jobs.eval_train_views = o.eval_train_views;
  jobs.refine_rows = o.refine_rows;
  jobs.detail_row = o.detail_row;
  return jobs;
}

}  // namespace lrf
