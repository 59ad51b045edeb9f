#pragma once
// The pipeline's per-scene work as one list of units, made once and gone through by both the sequential run
// (after Stage I and Stage III) and each --shard (its share, leaving what needs a stage not yet made): the
// training scenes' fields, and each evaluation scene's fields, refinements and scored rows.
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "lrf/pipeline/pipeline_jobs.h"
#include "lrf/pipeline/pipeline_paths.h"
#include "lrf/pipeline/pipeline_report.h"
#include "lrf/pipeline/pipeline_scenes.h"

namespace lrf {

// The training stages a unit needs finished first.
struct UnitNeeds {
  bool encoder = false;        // Stage I
  bool decoder_stock = false;  // Stage III on the stock-encoder fields
  bool decoder_ft = false;     // Stage III on the Stage I fields
};

struct PipelineUnit {
  std::string name;  // e.g. "stock rows of fern"
  UnitNeeds needs;
  std::function<void()> work;
};

// The training scenes' fields, stock and Stage I encoder ("ft").
std::vector<PipelineUnit> training_field_units(const PipelineJobs& jobs, const PipelineScenes& scenes,
                                               const PipelinePaths& paths);

// Each evaluation scene's fields and rows, in ablation_rows()'s groups: the stock rows, the decoder row, the
// Stage I rows, the both rows (with their refinement and detail pass) and each RGB baseline. Each unit
// puts the scores it made or reused, and where its test-view images are, into `scored` (by scene folder).
std::vector<PipelineUnit> evaluation_units(const PipelineJobs& jobs, const PipelineScenes& scenes,
                                           const PipelinePaths& paths, std::map<std::string, EvaluatedScene>* scored);

}  // namespace lrf
