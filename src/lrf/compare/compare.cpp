#include "lrf/compare/compare.h"

#include <filesystem>
#include <optional>

#include "lrf/compare/compare_methods.h"
#include "lrf/compare/compare_plan.h"
#include "lrf/compare/compare_report.h"
#include "lrf/core/artefact.h"
#include "lrf/core/error.h"
#include "lrf/detail/detail_eval.h"
#include "lrf/field_kinds/field_type.h"
#include "lrf/core/folder_lock.h"
#include "lrf/core/log.h"
#include "lrf/core/option_parts.h"
#include "lrf/core/paths.h"
#include "lrf/core/run_info.h"
#include "lrf/latent/latent_field.h"
#include "lrf/latent/latent_run.h"
#include "lrf/latent/latent_train_run.h"
#include "lrf/nerf/nerf_run.h"
#include "lrf/nerf/nerf_train_run.h"
#include "lrf/points/initial_points.h"
#include "lrf/refine/refine.h"
#include "lrf/refine/refine_folder.h"
#include "lrf/rgb/rgb_train_run.h"
#include "lrf/scene/scene.h"
#include "lrf/splat/run/train_run.h"

namespace fs = std::filesystem;

namespace lrf {

namespace {

// What every method's field depends on beyond its own name. Finished methods are reused, so a folder made
// with other settings is refused rather than mixed into one table.
nlohmann::json compare_settings(const CompareOptions& o) {
  nlohmann::json settings = {{"scene", canonical_path(o.scene)},
          {"images", o.scene_options.images_dir},
          {"downscale", o.scene_options.downscale},
          {"test_every", o.scene_options.test_every},
          {"train_views", o.scene_options.train_views},
          {"iters", o.iters},
          {"latent_iters", o.latent_iters},
          {"seed", o.seed},
          {"init_points", o.init_points.mode},
          {"far_shell", o.init_points.shell.points},
          {"view_images", kViewImagesVersion}};
  // A K-view split triangulates its own start; a folder made by an earlier track rule is not reused.
  if (const std::optional<int> rule = few_shot_track_rule(o.init_points.mode, o.scene_options.train_views)) {
    settings["initial_points_min_track_length"] = *rule;
  }
  return settings;
}

// The methods in a compare folder share its settings (compare.json): a folder made with others is refused.
void require_compare_settings(const std::string& summary_path, const nlohmann::json& wanted) {
  if (!fs::exists(summary_path)) return;
  const nlohmann::json recorded = read_json_file(summary_path).value("settings", nlohmann::json());
  if (!recorded.is_object()) return;  // written before compare recorded its settings
  require_same_settings(summary_path, recorded, wanted, "this folder holds methods",
                        "use another output folder, or --force to retrain every method");
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

}  // namespace

const std::vector<std::string>& compare_methods() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> v;
    for (const auto& m : compare_method_table()) v.push_back(m.name);
    return v;
  }();
  return names;
}

namespace {

// One compare run: each method's field made, resumed or reused, and scored. The latent field is shared by
// the latent row and what latent-refined starts from; latent-refined+detail scores latent-refined's field.
class CompareRun {
 public:
  CompareRun(const CompareOptions& o, const SceneOptions& scene_options)
      : o_(o),
        scene_options_(scene_options),
        nerf_iters_(o.nerf_iters > 0 ? o.nerf_iters : nerf::kDefaultNerfIters),
        latent_dir_(dir_of("latent")),
        refined_dir_(dir_of("latent-refined")) {}

  nlohmann::json scores(const std::string& method) {
    const CompareMethod& m = compare_method(method);
    const std::string dir = dir_of(method);
    require_recorded_shapes(m, dir);
    // The refined field is brought up to date first: a finished one is reused only if made with the refine
    // options asked for now (refine_folder.h), so that its row cannot pass for another setting's.
    const bool refined_now = m.job == CompareJob::refined_latent && ensure_refined_field_now();
    if (m.detail) return detail_scores(dir, refined_now);
    // Scores of an interrupted run (a checkpoint's point_cloud.ply) are not reused: the run is finished first.
    const std::string metrics = (fs::path(dir) / "metrics.json").string();
    if (!o_.force && !refined_now && fs::exists(metrics) && finished(m, dir)) {
      log_info(method + ": reusing " + metrics + " (pass --force to recompute)");
      return read_json_file(metrics);
    }
    const bool resume = resumable(m, dir);
    if (resume) log_info(method + ": resuming its run");
    switch (m.job) {
      case CompareJob::latent_field:
        ensure_latent_field();
        return scores_of(m.kind, dir, o_.scoring.decoder);
      case CompareJob::refined_latent:  // refined above, through the decoder it records
        return scores_of(m.kind, dir, "");
      case CompareJob::latent_nerf:
        return nerf_scores(m, dir, resume);
      case CompareJob::feature_field:
        return feature_scores(m, dir, resume);
      case CompareJob::rgb_field:
        break;
    }
    return rgb_scores(m, dir, resume);
  }

 private:
  std::string dir_of(const std::string& method) const { return (fs::path(o_.out) / compare_method_dir(method)).string(); }
  int feature_dim() const { return o_.feature_dim > 0 ? o_.feature_dim : kHalfLatentChannels; }

  // A latent NeRF's length is checked too: it is not in compare.json's settings.
  bool finished(const CompareMethod& m, const std::string& dir) const {
    if (!field_type(m.kind).finished(dir)) return false;
    if (m.job != CompareJob::latent_nerf) return true;
    const int64_t steps = nerf::recorded_nerf_options(dir).iters;
    if (steps != nerf_iters_ && !o_.force)
      fail(dir, "this latent NeRF was trained for " + std::to_string(steps) + " steps, not --nerf-steps " +
                    std::to_string(nerf_iters_) + ": use another output folder, or --force");
    return true;
  }
  bool resumable(const CompareMethod& m, const std::string& dir) const {
    return !o_.force && fs::exists(field_type(m.kind).checkpoint_path(dir)) && !finished(m, dir);
  }

  // A folder made with another feature count or SH degree is refused rather than reused (without --force).
  void require_recorded_shapes(const CompareMethod& m, const std::string& dir) const {
    if (o_.force) return;
    if (m.job == CompareJob::feature_field) require_same_feature_dim(dir, feature_dim());
    if (m.job == CompareJob::latent_field || m.job == CompareJob::refined_latent) {
      require_same_latent_sh_degree(latent_dir_, o_.latent_sh_degree);
      require_same_latent_sh_degree(dir, o_.latent_sh_degree);
    }
  }

  // What every Gaussian field of this compare is fitted with: its scene and views, points, seed and length.
  splat::GaussianFitOptions gaussian_fit(const std::string& out, int64_t iters, bool resume) const {
    splat::GaussianFitOptions f;
    copy_part<SceneFitOptions>(f, o_);
    f.out = out;
    f.scene_options = scene_options_;  // cropped to multiples of 8, the latent rows' views
    f.iters = iters;
    f.resume = resume;
    f.force = !resume;
    return f;
  }

  // The latent field's training options, shared by the latent row and the feature-gs baseline.
  LatentTrainOptions latent_field_options(const std::string& out, bool resume) const {
    LatentTrainOptions l;
    copy_part<splat::GaussianFitOptions>(l, gaussian_fit(out, o_.latent_iters > 0 ? o_.latent_iters : o_.iters, resume));
    copy_part<LatentSource>(l, o_);
    l.sh_degree = o_.latent_sh_degree;
    return l;
  }

  void ensure_latent_field() {
    if (!o_.force && splat::run_finished(latent_dir_)) return;
    if (latent_fresh_) return;
    const bool resume = resumable(compare_method("latent"), latent_dir_);
    log_info(std::string("== latent field") + (resume ? " (resuming)" : ""));
    train_latent_field(latent_field_options(latent_dir_, resume));
    latent_fresh_ = true;
  }

  // True if the refined field was (re)made now.
  bool ensure_refined_field_now() {
    ensure_latent_field();
    RefineOptions r = o_.refine;
    r.run = latent_dir_;
    r.out = refined_dir_;
    r.decoder = o_.scoring.decoder;
    r.seed = o_.seed;
    r.cache_dir = o_.cache_dir;
    // A refinement of an older latent field (or any, with --force) is made again from the start.
    return ensure_refined_field(r, "the latent-refined field", "use another output folder, or --force",
                                o_.force || latent_fresh_);
  }

  // A row's scores, as lrf eval gives them for the method's kind of field.
  nlohmann::json scores_of(FieldKind kind, const std::string& dir, const std::string& decoder) const {
    FieldScoring scoring = o_.scoring;
    scoring.decoder = decoder;
    return field_type(kind).evaluate(dir, scoring);
  }

  // The detail pass has no field of its own and takes seconds: it is scored again every time, with the
  // options asked for now, on latent-refined's field and beside its scores.
  nlohmann::json detail_scores(const std::string& dir, bool refined_now) const {
    const std::string refined_metrics = (fs::path(refined_dir_) / "metrics.json").string();
    if (refined_now || !fs::exists(refined_metrics)) scores_of(FieldKind::latent, refined_dir_, "");
    const nlohmann::json base = read_json_file(refined_metrics);
    detail::DetailEvalOptions d = o_.scoring;
    d.decoder.clear();  // the refined field's own: the decoder it was refined through
    return detail::evaluate_with_detail(refined_dir_, dir, d, &base);
  }

  nlohmann::json nerf_scores(const CompareMethod& m, const std::string& dir, bool resume) const {
    if (o_.force || !finished(m, dir)) {
      nerf::LatentNerfOptions n;
      copy_part<SceneFitOptions>(n, gaussian_fit(dir, nerf_iters_, resume));
      copy_part<LatentSource>(n, o_);
      nerf::train_latent_nerf(n);
    }
    return scores_of(m.kind, dir, o_.scoring.decoder);
  }

  nlohmann::json feature_scores(const CompareMethod& m, const std::string& dir, bool resume) const {
    if (o_.force || !splat::run_finished(dir)) {
      // The latent field's training, with a feature field in place of latent features.
      LatentTrainOptions l = latent_field_options(dir, resume);
      l.feature_dim = feature_dim();
      l.sh_degree = 0;  // Feature 3DGS's features are view-independent
      train_latent_field(l);
    }
    return scores_of(m.kind, dir, o_.scoring.decoder);
  }

  nlohmann::json rgb_scores(const CompareMethod& m, const std::string& dir, bool resume) const {
    if (o_.force || !splat::run_finished(dir)) {
      RgbTrainOptions b;
      copy_part<splat::GaussianFitOptions>(b, gaussian_fit(dir, o_.iters, resume));
      b.factor = m.rgb_factor;
      b.mip = m.mip;
      b.task = "train-" + m.name;
      train_rgb_field(b);
    }
    return scores_of(m.kind, dir, "");
  }

  const CompareOptions& o_;
  const SceneOptions scene_options_;
  const int64_t nerf_iters_;
  const std::string latent_dir_, refined_dir_;
  bool latent_fresh_ = false;  // trained by this run (then a refined field made from an older one is stale)
};

SceneOptions compare_scene_options(const CompareOptions& o) {
  SceneOptions so = o.scene_options;
  so.crop_to_multiple_of_8 = true;
  return so;
}

}  // namespace

nlohmann::json run_compare(const CompareOptions& o) {
  for (const auto& m : o.methods) compare_method(m);  // an unknown name is refused before any work
  refuse_output_over_input(o.out, o.scene, "the scene folder");
  fs::create_directories(o.out);
  const FolderLock lock(o.out);  // each method's folder below is locked again by its own training job
  const std::string summary_path = (fs::path(o.out) / "compare.json").string();
  const nlohmann::json settings = compare_settings(o);
  if (!o.force) require_compare_settings(summary_path, settings);
  const SceneOptions so = compare_scene_options(o);
  const Scene scene = load_scene(o.scene, so);

  CompareRun run(o, so);
  nlohmann::json all = nlohmann::json::object();
  for (size_t i = 0; i < o.methods.size(); ++i) {
    const std::string& method = o.methods[i];
    log_info("== " + method + " (" + std::to_string(i + 1) + " of " + std::to_string(o.methods.size()) +
             "): " + compare_method_plan(method, o));
    all[method] = run.scores(method);
  }
  write_compare_outputs(o, all, scene);

  nlohmann::json summary = {
      {"methods", all}, {"settings", settings}, {"run", run_record({{"scene", o.scene}, {"iters", o.iters}})}};
  if (o.scene_options.train_views > 0) {
    std::vector<std::string> training_views;  // named in the report and compare.json when few-shot
    for (int i : scene.train_indices) training_views.push_back(scene.views[static_cast<size_t>(i)].name);
    summary["training_views"] = training_views;
  }
  write_json_file(summary_path, summary);
  return summary;
}

}  // namespace lrf
