#include "lrf/pipeline/stage_times.h"

#include <filesystem>

#include "lrf/core/error.h"
#include "lrf/core/run_info.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {

double number_or_zero(const nlohmann::json& object, const char* key) {
  const auto it = object.find(key);
  return it != object.end() && it->is_number() ? it->get<double>() : 0.0;
}

}  // namespace

double finetune_record_seconds(const std::string& record_path) {
  const nlohmann::json result = read_json_file(record_path).value("result", nlohmann::json::object());
  if (result.contains("seconds")) return number_or_zero(result, "seconds");
  return number_or_zero(result, "seconds_this_session");
}

double field_run_seconds(const std::string& run_dir) {
  const std::string config = (fs::path(run_dir) / "config.json").string();
  const nlohmann::json result = read_json_file(config).value("result", nlohmann::json::object());
  if (result.contains("refine_seconds")) return number_or_zero(result, "refine_seconds");
  return number_or_zero(result, "seconds") + number_or_zero(result, "encode_seconds");
}

void StageTimes::add(const std::string& stage, const std::string& what, int runs, double seconds) {
  rows_.push_back({{"stage", stage}, {"what", what}, {"runs", runs}, {"seconds", seconds}});
}

ReportTable StageTimes::table() const {
  ReportTable t;
  t.title = "Wall time per stage";
  t.header = {"stage", "what", "runs", "seconds", "minutes"};
  double total = 0;
  int runs = 0;
  auto row = [](const std::string& stage, const std::string& what, int n, double seconds) {
    return Row{stage, what, n, Cell(seconds, 0), Cell(seconds / 60.0, 1)};
  };
  for (const auto& r : rows_) {
    const double seconds = r["seconds"].get<double>();
    const int n = r["runs"].get<int>();
    t.rows.push_back(row(r["stage"].get<std::string>(), r["what"].get<std::string>(), n, seconds));
    total += seconds;
    runs += n;
  }
  t.rows.push_back(row("total", "", runs, total));
  return t;
}

}  // namespace lrf
