#pragma once
// `lrf pipeline`: the paper's three stages end to end, and its ablation (Table 3) on scenes that no
// stage was trained on.
//   Stage I   encoder fine-tuned on the training scenes                      DIR/stage1/encoder.safetensors
//   Stage II  latent fields of every scene with the stock and the new encoder DIR/fields/<scene>-{stock,ft}
//   Stage III decoders fine-tuned on the training scenes' fields: one on the   DIR/stage3/decoder-{stock,ft}.safetensors
//             stock-encoder fields (the "decoder only" row), one on the new-encoder fields ("both")
//   refine    the eval scenes' fields refined through a decoder against     DIR/fields/<scene>-{stock,ft}-refined
//             their own training images (stock field + stock decoder; Stage I field + Stage III decoder)
//   baselines RGB fields on each evaluation scene: rgb/8 and rgb/8-mip at     DIR/fields/<scene>-{rgb8,rgb8mip,
//             latent resolution, rgb and rgb-mip at full resolution            rgb,rgbmip}
//   detail    the both+refine field's frames with the detail pass (its nearest training photographs
//             carried in with its depth: detail/detail_frames.h), the both+refine+detail row
//   scores    DIR/eval/<scene>/<row>/metrics.json, DIR/ablation.csv / .md, DIR/report.html
// Every artefact is kept; a re-run reuses what is finished and resumes what was interrupted. DIR/pipeline.json
// records the inputs of every stage (the evidence that evaluation scenes fed no training).
// A few-shot protocol (eval_train_views = K > 0) names its evaluation-scene artefacts and its outputs with
// "-Kviews" (fields/<scene>-Kviews-stock, ablation-Kviews.csv, pipeline-Kviews.json, ...), so one folder
// holds the full and the few-shot tables, made from the same Stage I, Stage III and training fields.
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lrf/detail/detail_blend.h"
#include "lrf/finetune/decoder_finetune.h"
#include "lrf/finetune/encoder_finetune.h"
#include "lrf/refine/refine.h"

namespace lrf {

struct PipelineOptions {
  PipelineOptions() { stage3.weight_roundtrip = kRecommendedWeightRoundtrip; }
  std::vector<std::string> train_scenes, eval_scenes;
  std::string autoencoder = "taef2", out, lpips_weights, cache_dir;
  int max_side = 640;               // every scene's images are downscaled to fit (integer factor)
  EncoderFinetuneOptions stage1;    // steps, batch, lambdas, learning rate (scenes and paths are set here)
  int64_t field_iters = 7000;       // Stage II iterations per latent field, and the RGB baselines'
  // Stage III: steps, crop, loss and learning rate of both decoders (fields, encoder and paths are set here);
  // its encoded-image term is on (kRecommendedWeightRoundtrip: DecoderFinetuneOptions' comment says why 4).
  DecoderFinetuneOptions stage3;
  uint64_t seed = 0;
  int eval_train_views = 0;         // few-shot: the evaluation scenes' fields see K training views (0 = all)
  RefineOptions refine;             // the refined rows: steps, crop, learning rates (the rest is set here)
  bool rgb_baseline = true;         // the rgb/8 and rgb/8-mip rows
  bool rgb_full = false;            // the rgb and rgb-mip rows (full resolution: the most costly fields, on request)
  bool refine_rows = true;          // the stock+refine and both+refine rows
  bool detail_row = true;           // the both+refine+detail row (with refine_rows)
  detail::DetailOptions detail;     // that row's detail pass
  // --shard i/n: run only the i-th of n shares of the per-scene steps (see run_pipeline_shard).
  int shard_index = 0, shard_count = 1;
};

// Parses "i/n" (0 <= i < n) into the options' shard; throws lrf::Error naming the text otherwise.
void parse_shard(const std::string& text, PipelineOptions* options);

// The ablation rows, in table order: the image-space baselines (rgb/8, rgb/8-mip, rgb, rgb-mip), the paper's
// rows (stock, encoder, decoder, both), then the refined fields (stock+refine, both+refine), then
// both+refine with the detail pass (both+refine+detail).
const std::vector<std::string>& ablation_rows();

// Runs (or reuses) every step; returns the summary written to DIR/pipeline.json (DIR/pipeline-Kviews.json
// for K views), whose "table" is the path of the protocol's ablation table in Markdown. With a shard (n > 1)
// runs only that share of the per-scene steps instead and returns what it did and what it left:
// the per-scene steps are numbered in a fixed order, in units that keep a field together with
// what needs only it (a field, its refinement, their evaluations), and unit k belongs to shard k mod n.
// A shard runs its units whose inputs are finished and leaves the rest: it never runs Stage I or Stage III
// (single jobs, data-parallel on their own), nor the tables. Shards run side by side on one folder
// (each artefact is locked by the job writing it); the unsharded command afterwards reuses everything
// they finished and does the rest.
nlohmann::json run_pipeline(const PipelineOptions& options);

// Throws lrf::Error if any evaluation scene is (the same folder as) a training scene.
void check_no_overlap(const std::vector<std::string>& train_scenes, const std::vector<std::string>& eval_scenes);

}  // namespace lrf
