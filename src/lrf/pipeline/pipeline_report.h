#pragma once
// The pipeline's tables and report: the ablation table (per evaluation scene, then the mean over them,
// as the paper's Table 3 and Table 1), ablation.csv/.md, report.html with every test view, and the scores
// pipeline.json keeps.
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lrf/eval/test_view_report.h"
#include "lrf/pipeline/pipeline_jobs.h"
#include "lrf/pipeline/pipeline_paths.h"
#include "lrf/pipeline/pipeline_scenes.h"
#include "lrf/eval/report.h"

namespace lrf {

// One evaluation scene's rows: their scores and where their test-view images are.
struct EvaluatedScene {
  std::string label;                                // PipelinePaths::eval_label
  std::map<std::string, nlohmann::json> scores;     // by row (ablation_rows())
  std::map<std::string, std::string> image_dirs;    // by row: the folder of its test views' PNGs
  std::vector<TestViewPhoto> photos;                // the test views' photographs
  std::string resolution;                           // "LABEL images downscaled Nx to WxH", for the notes
};

// What pipeline.json keeps of the tables: "results" (per scene and row) and "mean" (scenes, scores, left out).
struct AblationRecord {
  nlohmann::json results, mean;
};

// Writes ablation.csv, ablation.md and report.html (with `stage_times` as its last table) of this protocol.
AblationRecord write_ablation(const PipelineJobs& jobs, const PipelineScenes& scenes, const PipelinePaths& paths,
                              const std::vector<EvaluatedScene>& evaluated, const ReportTable& stage_times);

}  // namespace lrf
