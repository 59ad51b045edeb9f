#pragma once
// The option records of the pipeline's jobs, made once from the pipeline's options: every step is given its
// own job's record, never the pipeline's options whole. A record holds what all artefacts of its kind share;
// the steps (pipeline_steps.h) set what differs from one artefact to the next (scene, folder, encoder,
// decoder).
#include <vector>

#include "lrf/detail/detail_eval.h"
#include "lrf/finetune/decoder_finetune.h"
#include "lrf/finetune/encoder_finetune.h"
#include "lrf/latent/latent_run.h"
#include "lrf/latent/latent_train_run.h"
#include "lrf/pipeline/pipeline.h"
#include "lrf/pipeline/pipeline_paths.h"
#include "lrf/pipeline/pipeline_scenes.h"
#include "lrf/refine/refine.h"
#include "lrf/rgb/rgb_train_run.h"

namespace lrf {

// An image-space baseline: row, field folder tag, resolution factor, Mip filters.
struct RgbBaseline {
  const char* row;
  const char* tag;
  int factor;
  bool mip;
};

struct PipelineJobs {
  EncoderFinetuneOptions stage1;      // Stage I, whole: the training scenes, their resolutions, the encoder's path
  DecoderFinetuneOptions stage3;      // Stage III: fields, encoder and out are each decoder's
  LatentTrainOptions latent_field;    // Stage II: scene, views, out and encoder are each field's
  RgbTrainOptions rgb_field;          // the baselines (at the evaluation protocol's views): scene, out, factor, Mip
  std::vector<RgbBaseline> baselines; // the baselines made (the full-resolution ones with --rgb-full only)
  RefineOptions refine;               // the refined rows: run, out and decoder are each field's
  detail::DetailEvalOptions scoring;  // every row's LPIPS weights, and the detail row's pass
  int eval_train_views = 0;           // the evaluation scenes' fields see K training views (0: all)
  bool refine_rows = true, detail_row = true;  // the refined rows; the detail row (with them)
};

PipelineJobs pipeline_jobs(const PipelineOptions& o, const PipelineScenes& scenes, const PipelinePaths& paths);

}  // namespace lrf
