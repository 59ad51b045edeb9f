#include "lrf/compare/compare_report.h"

#include <algorithm>
#include <filesystem>
#include <map>
#include <optional>

#include "lrf/compare/compare_methods.h"
#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/core/run_info.h"
#include "lrf/eval/chart.h"
#include "lrf/eval/report.h"
#include "lrf/eval/table.h"
#include "lrf/eval/test_view_report.h"
#include "lrf/latent/latent_field.h"
#include "lrf/nerf/nerf_run.h"
#include "lrf/nerf/nerf_train_run.h"
#include "lrf/refine/refine.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {

// What a method's field is fitted to: the paper's efficiency table compares methods by the size of what
// they optimise against as well as by time and memory.
std::string fitted_to(const std::string& method, const std::string& dir, const Camera& camera) {
  const std::string full = std::to_string(camera.width) + "x" + std::to_string(camera.height);
  const std::string eighth = std::to_string(camera.width / 8) + "x" + std::to_string(camera.height / 8);
  const CompareMethod& m = compare_method(method);
  if (m.job == CompareJob::rgb_field) return (m.rgb_factor == 1 ? full : eighth) + " RGB";
  if (m.detail) {
    return fitted_to("latent-refined", (fs::path(dir).parent_path() / compare_method_dir("latent-refined")).string(), camera) +
           ", with the training photographs";
  }
  std::string channels = "?";
  const fs::path config = fs::path(dir) / "config.json";
  if (fs::exists(config)) {
    const nlohmann::json c = read_json_file(config.string());
    if (c.contains("background") && c["background"].is_array()) channels = std::to_string(c["background"].size());
  }
  std::string latents = eighth + "x" + channels + " latents";
  if (m.job == CompareJob::feature_field && fs::exists(config)) {
    // The field renders fewer channels than the latent has: name both.
    const nlohmann::json c = read_json_file(config.string());
    latents = eighth + "x" + c.value("latent_channels", nlohmann::json()).dump() + " latents, from " +
              c.value("feature_dim", nlohmann::json()).dump() + " features by a 1x1 convolution";
  }
  return m.job == CompareJob::refined_latent ? latents + ", then " + full + " RGB through the decoder" : latents;
}

// One sentence for each Gaussian-field method this run has, for the report's notes (the notes describe the
// rows of the table, not every method compare knows; latent-nerf has a note of its own).
std::string method_notes(const CompareOptions& o) {
  const std::map<std::string, std::string> notes = {
      {"rgb/8", "rgb/8: RGB 3D Gaussian splatting trained on the views downscaled 8x and rendered at full "
                "resolution (the paper's 3DGS/8)."},
      {"rgb/8-mip", "rgb/8-mip: RGB 3D Gaussian splatting with Mip-Splatting's filters, trained on the views "
                    "downscaled 8x and rendered at full resolution (the paper's Mip-Splatting/8)."},
      {"rgb", "rgb: RGB 3D Gaussian splatting on the full-resolution views."},
      {"rgb-mip", "rgb-mip: RGB 3D Gaussian splatting with Mip-Splatting's filters on the full-resolution views."},
      {"latent", "latent: a latent field with the " + o.autoencoder + " autoencoder, decoded (the paper's 3DGS-VAE)."},
      {"latent-refined", "latent-refined: the latent field refined through the decoder against the training "
                         "images (lrf refine: " + refine_description(o.refine) + ")."},
      {"latent-refined+detail", "latent-refined+detail: latent-refined's frames with the detail pass: the " +
                                    std::to_string(o.scoring.detail.views) + " nearest training photographs carried into "
                                    "each view with the field's depth and blended in where they agree with it and "
                                    "with one another (docs/detail.md)."},
      {"feature-gs", "feature-gs: the Feature-GS baseline (Feature 3DGS's speed-up module): Gaussians carrying " +
                         (o.feature_dim > 0 ? std::to_string(o.feature_dim) + " features"
                                            : std::string("half as many features as the latent has channels")) +
                         ", rendered at latent resolution, lifted to the latent by a 1x1 convolution trained with "
                         "them on the latent field's targets and loss, decoded."}};
  std::string text;
  for (const auto& method : o.methods) {
    const auto it = notes.find(method);
    if (it != notes.end()) text += " " + it->second;
  }
  return text;
}

// Frames per second of a whole view: the field's render, then, for a latent row, the decoder's pass, and
// for a row with the detail pass, that pass. This is the rate to compare across rows; a latent row's render
// rate alone "won" while its view needed the decoder at 4.6 fps.
Cell view_fps(const nlohmann::json& m) {
  const Cell render = Cell::number_in(m, "render_fps"), decode = Cell::number_in(m, "decode_fps");
  if (render.missing() || !(render.number > 0)) return Cell();
  const Cell detail = Cell::number_in(m, "detail_ms");
  const double detail_seconds = detail.missing() ? 0.0 : detail.number / 1000.0;
  if (decode.missing()) return Cell(1.0 / (1.0 / render.number + detail_seconds));
  if (!(decode.number > 0)) return Cell();
  return Cell(1.0 / (1.0 / render.number + 1.0 / decode.number + detail_seconds));
}

// The paper's efficiency table (training time, memory, storage, render and decode speed) for these methods
// (efficiency.csv keeps PSNR and SSIM beside them, for machines; the report shows them once, above).
ReportTable efficiency_table(const CompareOptions& o, const nlohmann::json& all, const Camera& camera) {
  ReportTable t;
  t.title = "Efficiency";
  t.header = {"method",     "fitted_to",  "train_seconds", "peak_memory_mb", "storage_mb", "gaussians",
              "render_fps", "decode_fps", "view_fps"};
  // Render and decode rates are parts of a view's cost, not rivals: only the whole view's rate is marked.
  t.better = {Better::none, Better::none, Better::lower, Better::lower, Better::lower,
              Better::none, Better::none, Better::none,  Better::higher};
  for (const auto& method : o.methods) {
    const auto& m = all[method];
    Row row = {method, fitted_to(method, (fs::path(o.out) / compare_method_dir(method)).string(), camera)};
    for (size_t k = 2; k + 1 < t.header.size(); ++k) row.push_back(Cell::number_in(m, t.header[k].c_str()));
    row.push_back(view_fps(m));
    t.rows.push_back(std::move(row));
  }
  return t;
}

// efficiency.csv's columns: the table's, with PSNR and SSIM (its layout before view_fps).
void write_efficiency_csv(const std::string& path, const ReportTable& t, const CompareOptions& o, const nlohmann::json& all) {
  std::vector<std::string> header(t.header.begin(), t.header.end() - 1);
  header.push_back("psnr");
  header.push_back("ssim");
  header.push_back("view_fps");
  std::vector<Row> rows;
  for (size_t i = 0; i < t.rows.size(); ++i) {
    Row row(t.rows[i].begin(), t.rows[i].end() - 1);
    row.push_back(Cell::number_in(all[o.methods[i]], "psnr"));
    row.push_back(Cell::number_in(all[o.methods[i]], "ssim"));
    row.push_back(t.rows[i].back());
    rows.push_back(std::move(row));
  }
  write_table_csv(path, header, rows);
}

// The test views' PSNR against the wall time of the whole row (encode, fit, refine) of the latent-refined
// row, when it scored itself as it refined, and of the curves given with --curve.
std::optional<Chart> quality_chart(const CompareOptions& o) {
  Chart chart;
  chart.title = "Test-view PSNR against wall time (encode + fit + refine)";
  chart.x_label = "wall time of the whole row, s";
  chart.y_label = "PSNR, dB";
  const fs::path own = fs::path(o.out) / compare_method_dir("latent-refined") / "curve.csv";
  if (std::find(o.methods.begin(), o.methods.end(), "latent-refined") != o.methods.end() && fs::exists(own))
    chart.series.push_back({"latent-refined (this run)", read_csv_series(own.string(), "seconds", "psnr")});
  for (const auto& c : o.curves) {
    const size_t eq = c.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == c.size())
      fail("compare: --curve takes NAME=CSV (a curve.csv of lrf refine --score-every), got '" + c + "'");
    chart.series.push_back({c.substr(0, eq), read_csv_series(c.substr(eq + 1), "seconds", "psnr")});
  }
  if (chart.series.empty()) return std::nullopt;
  return chart;
}


// Scores of every method: table.csv keeps every column; table.md the quality ones, as the report's summary.
struct QualityTable {
  std::vector<std::string> header;
  std::vector<Row> rows;
};

QualityTable write_tables(const CompareOptions& o, const nlohmann::json& all, const ReportTable& efficiency) {
  const std::vector<std::string> header = {"method",        "psnr",      "ssim",       "ms_ssim",
                                           "flip",          "lpips",     "train_seconds", "gaussians",
                                           "storage_mb",    "render_fps", "decode_fps", "peak_memory_mb"};
  std::vector<Row> rows;
  for (const auto& method : o.methods) {
    const auto& m = all[method];
    Row row = {method};
    for (size_t k = 1; k < header.size(); ++k) row.push_back(Cell::number_in(m, header[k].c_str()));
    rows.push_back(std::move(row));
  }
  write_table_csv((fs::path(o.out) / "table.csv").string(), header, rows);
  // What a person reads: one table per question, quality here and cost in the efficiency table.
  constexpr size_t kQualityColumns = 6;  // method, psnr, ssim, ms_ssim, flip, lpips
  QualityTable quality{{header.begin(), header.begin() + kQualityColumns}, {}};
  for (const Row& r : rows) quality.rows.emplace_back(r.begin(), r.begin() + kQualityColumns);
  write_table_markdown((fs::path(o.out) / "table.md").string(), quality.header, quality.rows);
  write_efficiency_csv((fs::path(o.out) / "efficiency.csv").string(), efficiency, o, all);
  write_table_markdown((fs::path(o.out) / "efficiency.md").string(), efficiency.header, efficiency.rows);
  return quality;
}

std::vector<std::string> report_notes(const CompareOptions& o, const nlohmann::json& all, const Scene& scene) {
  std::vector<std::string> notes;
  const Camera& c0 = scene.views[0].camera;
  if (o.scene_options.train_views > 0) {
    std::string names;
    for (int i : scene.train_indices) names += (names.empty() ? "" : ", ") + scene.views[static_cast<size_t>(i)].name;
    notes.push_back("Few-shot: every method trained on " + std::to_string(o.scene_options.train_views) +
                    " views, evenly spaced over the non-test views (" + names +
                    "), with initial points triangulated from them (unless --init-points says otherwise).");
  }
  notes.push_back("Scene " + o.scene + ", test views every " + std::to_string(o.scene_options.test_every) + "th, scored at " +
                  std::to_string(c0.width) + "x" + std::to_string(c0.height) + " (latent " +
                  std::to_string(c0.width / 8) + "x" + std::to_string(c0.height / 8) + "), " +
                  std::to_string(o.iters) + " training steps." + method_notes(o));
  notes.push_back("Fit time is the wall time of everything a row needs: the fit, and for the latent rows "
                  "also the encoding of the training views (as long as reading them from the latent cache took, "
                  "when they were cached), for latent-refined also its refinement.");
  const int64_t nerf_iters = o.nerf_iters > 0 ? o.nerf_iters : nerf::kDefaultNerfIters;
  if (std::find(o.methods.begin(), o.methods.end(), "latent-nerf") != o.methods.end())
    notes.push_back("latent-nerf: a hash-grid NeRF (Instant-NGP's architecture) fitted by volume rendering to the "
                    "same normalised latents as the latent field, decoded the same way (the paper's "
                    "Latent-NeRF*); " + std::to_string(nerf_iters) + " steps.");
  if (!all.empty() && all.begin()->value("lpips", nlohmann::json()).is_null())
    notes.push_back("LPIPS not computed: pass --lpips-weights with the lpips v0.1 VGG weights.");
  return notes;
}

}  // namespace

std::string compare_method_dir(const std::string& method) {
  std::string d = method;
  for (auto& c : d)
    if (c == '/') c = '_';
  return d;
}

void write_compare_outputs(const CompareOptions& o, const nlohmann::json& all, const Scene& scene) {
  const ReportTable efficiency = efficiency_table(o, all, scene.views[0].camera);
  const QualityTable quality = write_tables(o, all, efficiency);
  ReportSpec spec;
  spec.title = "lrf compare: " + fs::path(o.scene).filename().string();
  spec.summary_header = quality.header;
  spec.summary_rows = quality.rows;
  spec.tables.push_back(efficiency);
  spec.summary_better = {Better::none, Better::higher, Better::higher, Better::higher, Better::lower, Better::lower};
  spec.notes = report_notes(o, all, scene);
  spec.max_image_side = 640;
  std::vector<TestViewPhoto> photos;
  for (int i : scene.test_indices) photos.push_back({scene.views[static_cast<size_t>(i)].name, scene.load_image(i)});
  std::vector<ScoredRow> rows;
  for (const auto& method : o.methods)
    rows.push_back({method, (fs::path(o.out) / compare_method_dir(method) / "eval").string(), all[method]});
  spec.views = test_view_report(photos, rows, {{"psnr", "PSNR"}, {"ssim", "SSIM"}, {"flip", "FLIP"}, {"lpips", "LPIPS"}});
  if (const std::optional<Chart> chart = quality_chart(o)) spec.charts.push_back(*chart);
  write_html_report((fs::path(o.out) / "report.html").string(), spec);
}

}  // namespace lrf
