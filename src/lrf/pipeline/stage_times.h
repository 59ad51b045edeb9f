#pragma once
// Wall time per stage of a pipeline folder, read back from the records each stage wrote when it finished
// (so a folder finished over several sessions, resumed or reused, still adds up every stage's own
// time): Stage I's encoder, Stage II's latent fields, Stage III's decoders, the refinements and the
// image-space baselines. Time spent between a stage's last checkpoint and an interruption is not counted
// (those steps are made again), nor is scoring.
#include <string>

#include <nlohmann/json.hpp>

#include "lrf/eval/report.h"

namespace lrf {

// Seconds a Stage I or Stage III fine-tuning took, from its record (its "result"."seconds", or for records
// written before that existed, the last session's "seconds_this_session").
double finetune_record_seconds(const std::string& record_path);
// Seconds a finished field took to make, from RUN/config.json: for a refined field, its refinement alone;
// for a latent field, encoding its views and fitting it; for an RGB field, fitting it.
double field_run_seconds(const std::string& run_dir);

class StageTimes {
 public:
  // One row: the stage, what it made, how many runs, their seconds together.
  void add(const std::string& stage, const std::string& what, int runs, double seconds);
  // Columns stage, what, runs, seconds, minutes; the last row is the total.
  ReportTable table() const;
  // The same rows for a record: [{"stage", "what", "runs", "seconds"}, ...], without the total.
  const nlohmann::json& json() const { return rows_; }

 private:
  nlohmann::json rows_ = nlohmann::json::array();  // what table() and json() are made from
};

}  // namespace lrf
