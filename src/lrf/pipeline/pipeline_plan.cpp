#include "lrf/pipeline/pipeline_plan.h"

#include <filesystem>

#include "lrf/pipeline/pipeline_steps.h"

namespace fs = std::filesystem;

namespace lrf {

std::vector<PipelineUnit> training_field_units(const PipelineJobs& jobs, const PipelineScenes& scenes,
                                               const PipelinePaths& paths) {
  std::vector<PipelineUnit> units;
  for (const auto& s : scenes.train) {
    // Stage III learns from every view of a training scene.
    units.push_back({"field " + paths.field(s, "stock"), {}, [&jobs, &scenes, &paths, s] {
                       ensure_latent_field(jobs.latent_field, s, scenes.used.at(s), 0, paths.field(s, "stock"), "");
                     }});
    units.push_back({"field " + paths.field(s, "ft"), {true, false, false}, [&jobs, &scenes, &paths, s] {
                       ensure_latent_field(jobs.latent_field, s, scenes.used.at(s), 0, paths.field(s, "ft"), paths.encoder());
                     }});
  }
  return units;
}

std::vector<PipelineUnit> evaluation_units(const PipelineJobs& jobs, const PipelineScenes& scenes,
                                           const PipelinePaths& paths, std::map<std::string, EvaluatedScene>* scored) {
  std::vector<PipelineUnit> units;
  for (const auto& s : scenes.eval) {
    const SceneResolution& resolution = scenes.used.at(s);
    const std::string label = paths.eval_label(s);
    const std::string stock_field = paths.eval_field(s, "stock"), ft_field = paths.eval_field(s, "ft");
    const std::string stock_refined = paths.eval_field(s, "stock-refined"), ft_refined = paths.eval_field(s, "ft-refined");
    // A row's scores (field decoded by `decoder`, "": the one it records), kept with its images' folder.
    auto row = [&jobs, &paths, scored, s](const std::string& name, const std::string& field, const std::string& decoder) {
      const std::string dir = paths.eval(s, name);
      EvaluatedScene& scene = (*scored)[s];
      scene.scores[name] = ensure_latent_eval(jobs.scoring, field, decoder, dir);
      scene.image_dirs[name] = (fs::path(dir) / "eval").string();
    };
    units.push_back({"stock rows of " + label, {}, [=, &jobs] {
                       ensure_latent_field(jobs.latent_field, s, resolution, jobs.eval_train_views, stock_field, "");
                       row("stock", stock_field, "");
                       if (!jobs.refine_rows) return;
                       refine_eval_field(jobs.refine, stock_field, "", stock_refined);  // through its decoder, recorded
                       row("stock+refine", stock_refined, "");
                     }});
    units.push_back({"decoder row of " + label, {false, true, false}, [=, &jobs, &paths] {
                       ensure_latent_field(jobs.latent_field, s, resolution, jobs.eval_train_views, stock_field, "");
                       row("decoder", stock_field, paths.decoder("stock"));
                     }});
    units.push_back({"Stage I rows of " + label, {true, false, false}, [=, &jobs, &paths] {
                       ensure_latent_field(jobs.latent_field, s, resolution, jobs.eval_train_views, ft_field, paths.encoder());
                       row("encoder", ft_field, "");
                     }});
    units.push_back({"both rows of " + label, {true, false, true}, [=, &jobs, &paths] {
                       ensure_latent_field(jobs.latent_field, s, resolution, jobs.eval_train_views, ft_field, paths.encoder());
                       row("both", ft_field, paths.decoder("ft"));
                       if (!jobs.refine_rows) return;
                       refine_eval_field(jobs.refine, ft_field, paths.decoder("ft"), ft_refined);
                       row("both+refine", ft_refined, "");
                       if (!jobs.detail_row) return;
                       const std::string dir = paths.eval(s, "both+refine+detail");
                       EvaluatedScene& scene = (*scored)[s];
                       scene.scores["both+refine+detail"] =
                           ensure_detail_eval(jobs.scoring, ft_refined, dir, scene.scores.at("both+refine"));
                       scene.image_dirs["both+refine+detail"] = (fs::path(dir) / "eval").string();
                     }});
    for (const RgbBaseline& b : jobs.baselines) {
      units.push_back({std::string(b.row) + " of " + label, {}, [=, &jobs, &paths] {
                         const std::string rgb = paths.eval_field(s, b.tag);
                         ensure_rgb_field(jobs.rgb_field, s, resolution, rgb, b);
                         EvaluatedScene& scene = (*scored)[s];
                         scene.scores[b.row] = ensure_rgb_eval(jobs.scoring, rgb);
                         scene.image_dirs[b.row] = (fs::path(rgb) / "eval").string();
                       }});
    }
  }
  return units;
}

}  // namespace lrf
