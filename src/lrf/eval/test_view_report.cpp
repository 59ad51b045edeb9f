#include "lrf/eval/test_view_report.h"

#include <filesystem>

#include "lrf/core/image_io.h"

namespace fs = std::filesystem;

namespace lrf {

std::vector<ReportView> test_view_report(const std::vector<TestViewPhoto>& photos, const std::vector<ScoredRow>& rows,
                                         const std::vector<std::pair<std::string, std::string>>& numbers,
                                         const std::string& prefix) {
  std::vector<ReportView> views;
  for (const TestViewPhoto& photo : photos) {
    ReportView rv;
    rv.name = prefix + photo.name;
    rv.ground_truth = {"ground truth", photo.ground_truth, {}};
    const std::string png = fs::path(photo.name).stem().string() + ".png";
    for (const ScoredRow& row : rows) {
      const std::string path = (fs::path(row.image_dir) / png).string();
      ReportImage image{row.caption, fs::exists(path) ? read_image_rgb(path) : cv::Mat(), {}};
      for (const auto& view : row.scores.value("views", nlohmann::json::array())) {
        if (view.value("name", std::string()) != photo.name) continue;
        for (const auto& [key, label] : numbers) image.numbers.push_back({label, Cell::number_in(view, key.c_str())});
      }
      rv.methods.push_back(image);
    }
    views.push_back(std::move(rv));
  }
  return views;
}

}  // namespace lrf
