#include "lrf/pipeline/pipeline_report.h"

#include "lrf/core/atomic_file.h"
#include "lrf/core/log.h"
#include "lrf/eval/report.h"
#include "lrf/eval/table.h"
#include "lrf/pipeline/scene_mean.h"
#include "lrf/refine/refine.h"

namespace lrf {
namespace {

const std::vector<std::string>& ablation_header() {
  static const std::vector<std::string> header = {"scene", "method",  "psnr",        "delta_psnr",    "ssim",
                                                  "ms_ssim", "flip", "lpips", "latent_psnr", "roundtrip_psnr"};
  return header;
}

bool image_space_row(const std::string& row) { return row.rfind("rgb", 0) == 0; }

// One scene's rows of the table, in ablation_rows()'s order, with each row's PSNR against the stock row's;
// and the scores pipeline.json keeps of them.
void add_scene_rows(const EvaluatedScene& scene, std::vector<Row>* rows, nlohmann::json* results) {
  const auto stock = scene.scores.find("stock");
  const double stock_psnr = stock == scene.scores.end() ? 0.0 : stock->second.value("psnr", 0.0);
  for (const auto& row : ablation_rows()) {
    const auto found = scene.scores.find(row);
    if (found == scene.scores.end()) continue;
    const nlohmann::json& r = found->second;
    const bool latent = !image_space_row(row);
    rows->push_back({scene.label, row, Cell::number_in(r, "psnr"),
                     r.contains("psnr") ? Cell(r["psnr"].get<double>() - stock_psnr) : Cell(),
                     Cell::number_in(r, "ssim"), Cell::number_in(r, "ms_ssim"), Cell::number_in(r, "flip"),
                     Cell::number_in(r, "lpips"), latent ? Cell::number_in(r, "latent_psnr") : Cell(),
                     latent ? Cell::number_in(r, "roundtrip_psnr") : Cell()});
    (*results)[scene.label][row] = {{"psnr", r.value("psnr", 0.0)},
                                    {"ssim", r.value("ssim", 0.0)},
                                    {"ms_ssim", r.value("ms_ssim", nlohmann::json())},
                                    {"flip", r.value("flip", nlohmann::json())},
                                    {"lpips", r.value("lpips", nlohmann::json())}};
  }
}

// Every test view of a scene, its photograph then each row's image, with the row's PSNR and FLIP of it.
std::vector<ReportView> scene_views(const EvaluatedScene& scene) {
  std::vector<ScoredRow> rows;
  for (const auto& row : ablation_rows()) {
    const auto dir = scene.image_dirs.find(row);
    if (dir == scene.image_dirs.end()) continue;
    const auto scores = scene.scores.find(row);
    rows.push_back({row, dir->second, scores == scene.scores.end() ? nlohmann::json() : scores->second});
  }
  return test_view_report(scene.photos, rows, {{"psnr", "PSNR"}, {"flip", "FLIP"}}, scene.label + " / ");
}

std::vector<std::string> report_notes(const PipelineJobs& jobs, const PipelineScenes& scenes, const PipelinePaths& paths,
                                      const std::vector<EvaluatedScene>& evaluated, const std::string& mean_note) {
  std::vector<std::string> notes;
  std::string train_list, eval_list, resolutions;
  for (const auto& s : scenes.train) train_list += (train_list.empty() ? "" : ", ") + scenes.argument.at(s);
  for (const auto& s : scenes.eval) eval_list += (eval_list.empty() ? "" : ", ") + scenes.argument.at(s);
  for (const auto& e : evaluated)
    if (!e.resolution.empty()) resolutions += std::string(resolutions.empty() ? "" : "; ") + e.resolution;
  notes.push_back("Training scenes (Stage I and Stage III): " + train_list + ". Evaluation scenes (unseen by both): " +
                  eval_list + ". Autoencoder " + jobs.latent_field.autoencoder + "; " +
                  (jobs.stage1.max_side > 0 ? "every scene without a --downscale of its own downscaled so its longer side "
                                    "is at most " + std::to_string(jobs.stage1.max_side) + " px"
                                  : std::string("every scene at its images' size unless it gives a --downscale")) +
                  "; latent fields of " + std::to_string(jobs.latent_field.iters) + " training steps.");
  if (!resolutions.empty()) notes.push_back("Evaluated at: " + resolutions + ".");
  if (!mean_note.empty()) notes.push_back(mean_note);
  if (jobs.eval_train_views > 0) {
    notes.push_back("Few-shot (" + paths.protocol.substr(1) + " in the scene names): the evaluation scenes' fields "
                    "(latent, refined and RGB) trained on only " + std::to_string(jobs.eval_train_views) +
                    " views, evenly spaced over the non-test views; Stage I, Stage III and the training scenes' "
                    "fields are the folder's own, shared with its full-view table (ablation.csv).");
  }
  notes.push_back("Rows as in the paper's Table 3: stock = latent field with the stock encoder, decoded by the stock "
                  "decoder; encoder = Stage I encoder; decoder = Stage III decoder fine-tuned on stock-encoder "
                  "fields; both = Stage I encoder and the decoder fine-tuned on its fields. stock+refine and "
                  "both+refine: those fields refined through their decoder against the scene's training images "
                  "(lrf refine: " + refine_description(jobs.refine) + "). Image-space baselines: rgb/8 and "
                  "rgb/8-mip = RGB 3DGS and Mip-Splatting trained at latent resolution (the paper's 3DGS/8 and "
                  "Mip-Splatting/8), rgb = RGB 3DGS at full resolution. \u0394 PSNR is against the stock row.");
  return notes;
}

}  // namespace

AblationRecord write_ablation(const PipelineJobs& jobs, const PipelineScenes& scenes, const PipelinePaths& paths,
                              const std::vector<EvaluatedScene>& evaluated, const ReportTable& stage_times) {
  const std::vector<std::string>& header = ablation_header();
  AblationRecord record;
  record.results = nlohmann::json::object();
  std::vector<Row> rows;
  std::vector<std::string> labels;
  ReportSpec spec;
  spec.title = "lrf pipeline: ablation";
  spec.max_image_side = 640;
  for (const EvaluatedScene& scene : evaluated) {
    labels.push_back(scene.label);
    add_scene_rows(scene, &rows, &record.results);
    for (ReportView& view : scene_views(scene)) spec.views.push_back(std::move(view));
  }
  // The mean over the evaluation scenes of every row (the paper's Table 1), below the per-scene rows, and
  // in the report as a table of its own; with one evaluation scene its mean is its own rows, shown once.
  const SceneMean mean = mean_over_scenes(header, rows, labels, ablation_rows());
  const std::string mean_title = "Mean over " + std::to_string(labels.size()) + " evaluation scene" +
                                 (labels.size() == 1 ? "" : "s");
  std::string mean_note;
  if (!mean.left_out.empty()) {
    mean_note = mean_title + " leaves out what a scene lacks: ";
    for (size_t i = 0; i < mean.left_out.size(); ++i) mean_note += (i ? "; " : "") + mean.left_out[i];
    mean_note += ".";
    log_info(mean_note);
  }
  const bool several_scenes = labels.size() > 1;
  if (several_scenes) rows.insert(rows.end(), mean.rows.begin(), mean.rows.end());
  const std::vector<Better> better = {Better::none,   Better::none,  Better::higher, Better::higher, Better::higher,
                                      Better::higher, Better::lower, Better::lower,  Better::higher, Better::higher};
  write_table_csv(paths.output("ablation", "csv"), header, rows);
  write_file_atomic(paths.output("ablation", "md"), table_markdown(header, rows, paths.output("ablation", "md")) +
                                                        (mean_note.empty() ? "" : "\n" + mean_note + "\n"));
  spec.summary_header = header;
  spec.summary_rows = rows;
  spec.summary_better = better;
  ReportTable mean_table{mean_title, {header.begin() + 1, header.end()}, {}, {better.begin() + 1, better.end()}};
  for (const Row& r : mean.rows) mean_table.rows.push_back(Row(r.begin() + 1, r.end()));
  if (several_scenes) spec.tables.push_back(mean_table);
  spec.notes = report_notes(jobs, scenes, paths, evaluated, mean_note);
  spec.tables.push_back(stage_times);
  write_html_report(paths.output("report", "html"), spec);

  nlohmann::json mean_scores = nlohmann::json::object();
  for (const Row& r : mean.rows) {
    for (size_t c = 2; c < header.size(); ++c)
      mean_scores[r[1].text][header[c]] = r[c].missing() ? nlohmann::json() : nlohmann::json(r[c].number);
  }
  record.mean = {{"scenes", labels}, {"scores", mean_scores}, {"left_out", mean.left_out}};
  return record;
}

}  // namespace lrf
