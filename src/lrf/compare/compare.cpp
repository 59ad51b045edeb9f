#include "lrf/compare/compare.h"

#include <algorithm>
#include <filesystem>
#include <map>
#include <optional>

#include <torch/torch.h>

#include "lrf/autoencoder/image_tensor.h"
#include "lrf/compare/compare_methods.h"
#include "lrf/compare/compare_plan.h"
#include "lrf/core/error.h"
#include "lrf/detail/detail_eval.h"
#include "lrf/core/folder_lock.h"
#include "lrf/core/image_io.h"
#include "lrf/core/log.h"
#include "lrf/core/paths.h"
#include "lrf/core/progress.h"
#include "lrf/core/resources.h"
#include "lrf/core/run_info.h"
#include "lrf/core/state_dict.h"
#include "lrf/eval/lpips.h"
#include "lrf/eval/report.h"
#include "lrf/eval/scores.h"
#include "lrf/eval/table.h"
#include "lrf/latent/latent_field.h"
#include "lrf/latent/latent_run.h"
#include "lrf/nerf/nerf_run.h"
#include "lrf/points/initial_points.h"
#include "lrf/refine/refine.h"
#include "lrf/refine/refine_folder.h"
#include "lrf/rgb/rgb_eval.h"
#include "lrf/rgb/rgb_train_run.h"
#include "lrf/scene/scene.h"
#include "lrf/splat/run/train_run.h"

namespace fs = std::filesystem;

namespace lrf {

namespace {

std::string method_dir(const std::string& method) {
  std::string d = method;
  for (auto& c : d)
    if (c == '/') c = '_';
  return d;
}

// What every method's field depends on beyond its own name. Finished methods are reused, so a folder made
// with other settings is refused rather than mixed into one table.
nlohmann::json compare_settings(const CompareOptions& o) {
  nlohmann::json settings = {{"scene", canonical_path(o.scene)},
          {"images", o.images},
          {"downscale", o.downscale},
          {"test_every", o.test_every},
          {"train_views", o.train_views},
          {"iters", o.iters},
          {"latent_iters", o.latent_iters},
          {"seed", o.seed},
          {"init_points", o.init_points.mode},
          {"far_shell", o.init_points.shell.points},
          {"view_images", kViewImagesVersion}};
  // A K-view split triangulates its own start; a folder made by an earlier track rule is not reused.
  if (const std::optional<int> rule = few_shot_track_rule(o.init_points.mode, o.train_views)) {
    settings["initial_points_min_track_length"] = *rule;
  }
  return settings;
}

void require_same_settings(const std::string& summary_path, const nlohmann::json& wanted) {
  if (!fs::exists(summary_path)) return;
  const nlohmann::json recorded = read_json_file(summary_path).value("settings", nlohmann::json());
  if (!recorded.is_object()) return;  // written before compare recorded its settings
  const std::string differ = differing_settings(recorded, wanted);
  if (!differ.empty()) {
    fail(summary_path, "this folder holds methods made with other settings:" + differ +
                           "; use another output folder, or --force to retrain every method");
  }
}

// A finished or interrupted feature-gs field is reused or resumed only with the feature count asked for now.
void require_same_feature_dim(const std::string& dir, int wanted) {
  const std::string config = (fs::path(dir) / "config.json").string();
  if (!fs::exists(config)) return;
  const nlohmann::json options = read_json_file(config).value("options", nlohmann::json::object());
  const nlohmann::json recorded = options.value("feature_dim", nlohmann::json());
  if (recorded == wanted) return;
  // kHalfLatentChannels is how both the option and the record say "the default".
  auto describe = [](const nlohmann::json& d) {
    if (!d.is_number_integer()) return std::string("an unknown feature count");
    return d.get<int>() == kHalfLatentChannels ? std::string("the default feature count (half the latent channels)")
                                               : std::to_string(d.get<int>()) + " features";
  };
  fail(config, "feature-gs was trained here with " + describe(recorded) + ", this run asks for " +
                   describe(wanted) + "; use another output folder, or --force");
}

// The latent field, and the refined field made from it, are reused or resumed only at the SH degree asked
// for now: the degree is not in compare.json's settings (the RGB rows do not depend on it), and the default
// changed from 0 to 1, so an older folder's latent rows would otherwise pass for the new default's.
void require_same_latent_sh_degree(const std::string& dir, int wanted) {
  const std::string config = (fs::path(dir) / "config.json").string();
  if (!fs::exists(config)) return;
  const nlohmann::json recorded = read_json_file(config).value("sh_degree", nlohmann::json());
  if (recorded == wanted) return;
  fail(config, "this field has SH degree " + (recorded.is_number_integer() ? recorded.dump() : "unknown") +
                   ", this run asks for --latent-sh-degree " + std::to_string(wanted) +
                   "; use another output folder, or --force");
}

// What a method's field is fitted to: the paper's efficiency table compares methods by the size of what
// they optimise against as well as by time and memory.
std::string fitted_to(const std::string& method, const std::string& dir, const Camera& camera) {
  const std::string full = std::to_string(camera.width) + "x" + std::to_string(camera.height);
  const std::string eighth = std::to_string(camera.width / 8) + "x" + std::to_string(camera.height / 8);
  const CompareMethod& m = compare_method(method);
  if (m.job == CompareJob::rgb_field) return (m.rgb_factor == 1 ? full : eighth) + " RGB";
  if (m.detail) {
    return fitted_to("latent-refined", (fs::path(dir).parent_path() / method_dir("latent-refined")).string(), camera) +
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
                                    std::to_string(o.detail.views) + " nearest training photographs carried into "
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
    Row row = {method, fitted_to(method, (fs::path(o.out) / method_dir(method)).string(), camera)};
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
  const fs::path own = fs::path(o.out) / method_dir("latent-refined") / "curve.csv";
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

}  // namespace

const std::vector<std::string>& compare_methods() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> v;
    for (const auto& m : compare_method_table()) v.push_back(m.name);
    return v;
  }();
  return names;
}

nlohmann::json run_compare(const CompareOptions& o) {
  for (const auto& m : o.methods) compare_method(m);  // an unknown name is refused before any work
  refuse_output_over_input(o.out, o.scene, "the scene folder");
  fs::create_directories(o.out);
  const FolderLock lock(o.out);  // each method's folder below is locked again by its own training job
  const std::string summary_path = (fs::path(o.out) / "compare.json").string();
  const nlohmann::json settings = compare_settings(o);
  if (!o.force) require_same_settings(summary_path, settings);
  SceneOptions so;
  so.images_dir = o.images;
  so.downscale = o.downscale;
  so.test_every = o.test_every;
  so.train_views = o.train_views;
  so.crop_to_multiple_of_8 = true;
  Scene scene = load_scene(o.scene, so);
  // A latent NeRF keeps its own files (nerf/nerf_run.h); every other method is a Gaussian field.
  const int64_t nerf_iters = o.nerf_iters > 0 ? o.nerf_iters : nerf::kDefaultNerfIters;
  auto finished = [&](const std::string& method, const std::string& dir) {
    if (compare_method(method).kind != FieldKind::latent_nerf) return splat::run_finished(dir);
    if (!nerf::nerf_run_finished(dir)) return false;
    const int64_t steps = nerf::recorded_nerf_options(dir).iters;
    if (steps != nerf_iters && !o.force)
      fail(dir, "this latent NeRF was trained for " + std::to_string(steps) + " steps, not --nerf-steps " +
                    std::to_string(nerf_iters) + ": use another output folder, or --force");
    return true;
  };
  auto resumable = [&](const std::string& method, const std::string& dir) {
    const std::string checkpoint = compare_method(method).kind == FieldKind::latent_nerf ? nerf::nerf_checkpoint_path(dir)
                                                                                         : splat::checkpoint_path(dir);
    return !o.force && fs::exists(checkpoint) && !finished(method, dir);
  };
  // The latent field's training options, shared by the latent row and the feature-gs baseline.
  auto latent_field_options = [&](const std::string& out, bool resume) {
    LatentTrainOptions l;
    l.scene = o.scene;
    l.out = out;
    l.scene_options = so;
    l.autoencoder = o.autoencoder;
    l.encoder = o.encoder;
    l.cache_dir = o.cache_dir;
    l.sh_degree = o.latent_sh_degree;
    l.init_points = o.init_points;
    l.iters = o.latent_iters > 0 ? o.latent_iters : o.iters;
    l.seed = o.seed;
    l.resume = resume;
    l.force = !resume;
    return l;
  };
  // The latent field: the latent row, and what latent-refined starts from.
  const std::string latent_dir = (fs::path(o.out) / "latent").string();
  bool latent_fresh = false;  // trained by this call (then a refined field made from an older one is stale)
  auto ensure_latent_field = [&] {
    if (!o.force && splat::run_finished(latent_dir)) return;
    if (latent_fresh) return;
    const bool resume = resumable("latent", latent_dir);
    log_info(std::string("== latent field") + (resume ? " (resuming)" : ""));
    train_latent_field(latent_field_options(latent_dir, resume));
    latent_fresh = true;
  };
  nlohmann::json all = nlohmann::json::object();
  for (size_t i = 0; i < o.methods.size(); ++i) {
    const std::string& method = o.methods[i];
    const CompareMethod& m = compare_method(method);
    const std::string dir = (fs::path(o.out) / method_dir(method)).string();
    log_info("== " + method + " (" + std::to_string(i + 1) + " of " + std::to_string(o.methods.size()) +
             "): " + compare_method_plan(method, o));
    const std::string metrics_path = (fs::path(dir) / "metrics.json").string();
    const int feature_dim = o.feature_dim > 0 ? o.feature_dim : kHalfLatentChannels;
    if (m.job == CompareJob::feature_field && !o.force) require_same_feature_dim(dir, feature_dim);
    if ((m.job == CompareJob::latent_field || m.job == CompareJob::refined_latent) && !o.force) {
      require_same_latent_sh_degree(latent_dir, o.latent_sh_degree);
      require_same_latent_sh_degree(dir, o.latent_sh_degree);
    }
    // The refined field is brought up to date first: a finished one is reused only if made with the refine
    // options asked for now (refine_folder.h), so that its row cannot pass for another setting's.
    bool refined_now = false;
    // latent-refined+detail scores latent-refined's field: one refinement serves both rows.
    const std::string refined_dir = (fs::path(o.out) / method_dir("latent-refined")).string();
    if (m.job == CompareJob::refined_latent) {
      ensure_latent_field();
      RefineOptions r = o.refine;
      r.run = latent_dir;
      r.out = refined_dir;
      r.decoder = o.decoder;
      r.seed = o.seed;
      r.cache_dir = o.cache_dir;
      // A refinement of an older latent field (or any, with --force) is made again from the start.
      refined_now = ensure_refined_field(r, "the latent-refined field", "use another output folder, or --force",
                                         o.force || latent_fresh);
    }
    // The detail pass has no field of its own and takes seconds: it is scored again every time, with the
    // options asked for now.
    if (m.detail) {
      const std::string refined_metrics = (fs::path(refined_dir) / "metrics.json").string();
      if (refined_now || !fs::exists(refined_metrics)) {
        LatentEvalOptions le;
        le.lpips_weights = o.lpips_weights;
        evaluate_latent_run(refined_dir, le);
      }
      const nlohmann::json base = read_json_file(refined_metrics);
      detail::DetailEvalOptions d;
      d.lpips_weights = o.lpips_weights;
      d.detail = o.detail;
      all[method] = detail::evaluate_with_detail(refined_dir, dir, d, &base);
      continue;
    }
    // Scores of an interrupted run (a checkpoint's point_cloud.ply) are not reused: the run is finished first.
    if (!o.force && !refined_now && fs::exists(metrics_path) && finished(method, dir)) {
      log_info(method + ": reusing " + metrics_path + " (pass --force to recompute)");
      all[method] = read_json_file(metrics_path);
      continue;
    }
    const bool resume = resumable(method, dir);
    if (resume) log_info(method + ": resuming its run");
    if (m.job == CompareJob::latent_field) {
      ensure_latent_field();
      LatentEvalOptions le;
      le.decoder = o.decoder;
      le.lpips_weights = o.lpips_weights;
      all[method] = evaluate_latent_run(dir, le);
    } else if (m.job == CompareJob::refined_latent) {  // refined above
      LatentEvalOptions le;
      le.lpips_weights = o.lpips_weights;
      all[method] = evaluate_latent_run(dir, le);
    } else if (m.job == CompareJob::latent_nerf) {
      if (o.force || !finished(method, dir)) {
        nerf::LatentNerfOptions n;
        n.scene = o.scene;
        n.out = dir;
        n.scene_options = so;
        n.autoencoder = o.autoencoder;
        n.encoder = o.encoder;
        n.cache_dir = o.cache_dir;
        n.init_points = o.init_points;
        n.iters = nerf_iters;
        n.seed = o.seed;
        n.resume = resume;
        n.force = !resume;
        nerf::train_latent_nerf(n);
      }
      LatentEvalOptions le;
      le.decoder = o.decoder;
      le.lpips_weights = o.lpips_weights;
      all[method] = nerf::evaluate_nerf_run(dir, le);
    } else if (m.job == CompareJob::feature_field) {
      if (o.force || !splat::run_finished(dir)) {
        // The latent field's training, with a feature field in place of latent features.
        LatentTrainOptions l = latent_field_options(dir, resume);
        l.feature_dim = feature_dim;
        l.sh_degree = 0;  // Feature 3DGS's features are view-independent
        train_latent_field(l);
      }
      LatentEvalOptions le;
      le.decoder = o.decoder;
      le.lpips_weights = o.lpips_weights;
      all[method] = evaluate_latent_run(dir, le);
    } else {
      if (o.force || !splat::run_finished(dir)) {
        RgbTrainOptions b;
        b.scene = o.scene;
        b.scene_options = so;  // cropped to multiples of 8, as the latent rows' views
        b.out = dir;
        b.factor = m.rgb_factor;
        b.iters = o.iters;
        b.mip = m.mip;
        b.seed = o.seed;
        b.resume = resume;
        b.force = !resume;
        b.init_points = o.init_points;
        b.task = "train-" + method;
        train_rgb_field(b);
      }
      RgbEvalOptions re;
      re.lpips_weights = o.lpips_weights;
      all[method] = evaluate_rgb_run(dir, re);
    }
  }

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
  const std::vector<std::string> quality_header(header.begin(), header.begin() + kQualityColumns);
  std::vector<Row> quality_rows;
  for (const Row& r : rows) quality_rows.emplace_back(r.begin(), r.begin() + kQualityColumns);
  write_table_markdown((fs::path(o.out) / "table.md").string(), quality_header, quality_rows);
  const ReportTable efficiency = efficiency_table(o, all, scene.views[0].camera);
  write_efficiency_csv((fs::path(o.out) / "efficiency.csv").string(), efficiency, o, all);
  write_table_markdown((fs::path(o.out) / "efficiency.md").string(), efficiency.header, efficiency.rows);

  ReportSpec spec;
  spec.title = "lrf compare: " + fs::path(o.scene).filename().string();
  spec.summary_header = quality_header;
  spec.summary_rows = quality_rows;
  spec.tables.push_back(efficiency);
  spec.summary_better = {Better::none, Better::higher, Better::higher, Better::higher, Better::lower, Better::lower};
  const Camera& c0 = scene.views[0].camera;
  std::vector<std::string> training_views;  // named in the report and compare.json when few-shot
  for (int i : scene.train_indices) training_views.push_back(scene.views[static_cast<size_t>(i)].name);
  if (o.train_views > 0) {
    std::string names;
    for (const auto& name : training_views) names += (names.empty() ? "" : ", ") + name;
    spec.notes.push_back("Few-shot: every method trained on " + std::to_string(o.train_views) +
                         " views, evenly spaced over the non-test views (" + names +
                         "), with initial points triangulated from them (unless --init-points says otherwise).");
  }
  spec.notes.push_back("Scene " + o.scene + ", test views every " + std::to_string(o.test_every) + "th, scored at " +
                       std::to_string(c0.width) + "x" + std::to_string(c0.height) + " (latent " +
                       std::to_string(c0.width / 8) + "x" + std::to_string(c0.height / 8) + "), " +
                       std::to_string(o.iters) + " training steps." + method_notes(o));
  spec.notes.push_back("Fit time is the wall time of everything a row needs: the fit, and for the latent rows "
                       "also the encoding of the training views (as long as reading them from the latent cache took, "
                       "when they were cached), for latent-refined also its refinement.");
  if (std::find(o.methods.begin(), o.methods.end(), "latent-nerf") != o.methods.end())
    spec.notes.push_back("latent-nerf: a hash-grid NeRF (Instant-NGP's architecture) fitted by volume rendering to the "
                         "same normalised latents as the latent field, decoded the same way (the paper's "
                         "Latent-NeRF*); " + std::to_string(nerf_iters) + " steps.");
  if (!all.empty() && all.begin()->value("lpips", nlohmann::json()).is_null())
    spec.notes.push_back("LPIPS not computed: pass --lpips-weights with the lpips v0.1 VGG weights.");
  spec.max_image_side = 640;
  for (int i : scene.test_indices) {
    const View& v = scene.views[static_cast<size_t>(i)];
    ReportView rv;
    rv.name = v.name;
    rv.ground_truth = {"ground truth", scene.load_image(i), {}};
    for (const auto& method : o.methods) {
      const std::string png =
          (fs::path(o.out) / method_dir(method) / "eval" / (fs::path(v.name).stem().string() + ".png")).string();
      ReportImage im{method, fs::exists(png) ? read_image_rgb(png) : cv::Mat(), {}};
      for (const auto& vj : all[method]["views"]) {
        if (vj.value("name", std::string()) == v.name) {
          im.numbers = {{"PSNR", Cell::number_in(vj, "psnr")},
                        {"SSIM", Cell::number_in(vj, "ssim")},
                        {"FLIP", Cell::number_in(vj, "flip")},
                        {"LPIPS", Cell::number_in(vj, "lpips")}};
        }
      }
      rv.methods.push_back(im);
    }
    spec.views.push_back(rv);
  }
  if (const std::optional<Chart> chart = quality_chart(o)) spec.charts.push_back(*chart);
  write_html_report((fs::path(o.out) / "report.html").string(), spec);
  nlohmann::json summary = {
      {"methods", all}, {"settings", settings}, {"run", run_record({{"scene", o.scene}, {"iters", o.iters}})}};
  if (o.train_views > 0) summary["training_views"] = training_views;
  write_json_file(summary_path, summary);
  return summary;
}

}  // namespace lrf
