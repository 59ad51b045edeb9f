#pragma once
// The report's test-view section, the same for compare and pipeline: per test view, its photograph and
// then each row's image of it (the PNG its evaluation wrote) captioned with that view's own scores.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "lrf/eval/report.h"

namespace lrf {

struct TestViewPhoto {
  std::string name;       // the view's image file name, as the scores' "views" entries name it
  cv::Mat ground_truth;
};

// One row of the report: its caption, the folder its evaluation wrote <view stem>.png into, and its scores
// (the "views" array of a metrics.json).
struct ScoredRow {
  std::string caption;
  std::string image_dir;
  nlohmann::json scores;
};

// One ReportView per photo, named `prefix` + its name; a row without the image shows a placeholder. Each
// image carries the scores named in `numbers` (metric key and label, e.g. {"psnr", "PSNR"}).
std::vector<ReportView> test_view_report(const std::vector<TestViewPhoto>& photos, const std::vector<ScoredRow>& rows,
                                         const std::vector<std::pair<std::string, std::string>>& numbers,
                                         const std::string& prefix = "");

}  // namespace lrf
