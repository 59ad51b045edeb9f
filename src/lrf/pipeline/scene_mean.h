#pragma once
// The mean over the evaluation scenes of every row of the ablation table: the paper's Table 1 reports
// each method as its mean over the scenes. A method's scores are averaged column by column, and only over
// complete sets: a method lacking its row for one scene gets no mean (a mean over fewer scenes would sit
// in the table beside means over all of them as if comparable), and neither does a score one scene lacks.
#include <string>
#include <vector>

#include "lrf/eval/table.h"

namespace lrf {

struct SceneMean {
  std::vector<Row> rows;               // "mean", method, then each score column's mean
  std::vector<std::string> left_out;   // what has no mean and why: "rgb/8: no row for llff-room",
                                       // "stock: lpips missing for llff-room"
};

// `rows`: per-scene rows of the form scene, method, scores (numbers or missing cells), with the columns
// `header` names (used in left_out). Gives one mean row
// per method of `methods` (in that order) that every scene of `scenes` has a row for. A score column is
// left missing in the mean if any scene lacks a number in it; that is named in left_out, unless no scene
// has one (a score not measured at all, e.g. LPIPS without its weights).
SceneMean mean_over_scenes(const std::vector<std::string>& header, const std::vector<Row>& rows,
                           const std::vector<std::string>& scenes, const std::vector<std::string>& methods);

}  // namespace lrf
