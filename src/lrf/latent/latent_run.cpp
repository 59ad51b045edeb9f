#include <filesystem>

#include <torch/torch.h>

#include "lrf/core/error.h"
#include "lrf/core/run_info.h"
#include "lrf/latent/latent_cache.h"
#include "lrf/latent/latent_config.h"
#include "lrf/latent/latent_field.h"
#include "lrf/latent/latent_run.h"
#include "lrf/latent/latent_scoring.h"
#include "lrf/latent/trained_run_checks.h"
#include "lrf/scene/run_scene_location.h"
#include "lrf/splat/run/run_folder.h"
#include "lrf/splat/ply_io.h"

namespace fs = std::filesystem;

namespace lrf {

LatentRun open_latent_run(const std::string& out) {
  LatentRun run;
  run.out = out;
  const std::string config_path = (fs::path(out) / "config.json").string();
  run.config = splat::read_run_config(out);
  const LatentConfig c = parse_latent_config(run.config, config_path);
  run.autoencoder = c.autoencoder;
  run.encoder = c.encoder;
  run.render.sh_degree = c.field.sh_degree;
  run.render.mip = false;
  run.render.background = torch::tensor(c.field.background);
  run.range = c.range;
  check_autoencoder_unchanged(run.autoencoder, run.encoder, c.identity, config_path);
  run.decoder = c.decoder;
  if (!run.decoder.empty() && weights_file_identity(run.decoder) != c.decoder_identity) {
    fail(config_path, "the decoder the field was refined through changed since (" + run.decoder + "): refine again, "
                      "or restore the weights");
  }
  const std::string scene_root = run_scene_root(run.config, config_path);
  run.scene = reload_trained_scene(scene_root, c.field.scene, c.resolution, config_path);
  check_run_scene_views(run.scene, run.config, config_path);
  run.config["scene"] = scene_root;  // where it was found: lrf refine records the config it copies
  const std::string ply = (fs::path(out) / "point_cloud.ply").string();
  if (!fs::exists(ply)) fail(ply, "not found: the run has not finished (resume it with lrf train --resume)");
  if (c.feature_dim > 0) {
    run.field = splat::read_ply(ply, c.feature_dim);
    const std::string lift = (fs::path(out) / "lift.safetensors").string();
    if (!fs::exists(lift)) fail(lift, "not found: a feature field needs the lift it was trained with");
    run.lift = FeatureLift::load(lift, c.feature_dim, run.range.channels());
  } else {
    run.field = splat::read_ply(ply, run.range.channels());
  }
  return run;
}

torch::Tensor render_latent(const LatentRun& run, int view) {
  return render_latent_at(run, latent_camera(run.scene.views.at(static_cast<size_t>(view)).camera));
}

torch::Tensor render_latent_at(const LatentRun& run, const Camera& latent_camera) {
  torch::Tensor rendered = splat::render_field(run.field, latent_camera, run.render).image;
  if (!run.lift.defined()) return rendered;
  torch::NoGradGuard no_grad;
  return run.lift.apply(rendered);
}

nlohmann::json evaluate_latent_run(const std::string& out, const LatentEvalOptions& o) {
  LatentRun run = open_latent_run(out);
  const std::string decoder = o.decoder.empty() ? run.decoder : o.decoder;
  nlohmann::json metrics = score_latent_run(out, run.scene, run.range, run.autoencoder, run.encoder, decoder, o,
                                            [&](int view) { return render_latent(run, view); });
  metrics["gaussians"] = run.field.size();
  std::error_code ec;
  const std::string field_file = (fs::path(out) / "point_cloud.ply").string();
  double storage = double(fs::file_size(field_file, ec));
  if (run.lift.defined()) {
    // A feature field is its Gaussians and its lift.
    storage += double(fs::file_size((fs::path(out) / "lift.safetensors").string(), ec));
    metrics["feature_dim"] = run.lift.feature_dim();
  }
  // A decoder the run made for itself (a refinement's) is part of what it takes to show a view; a shared
  // or stock decoder is not counted, as the paper's table counts fields.
  if (!decoder.empty() && fs::exists(decoder) &&
      fs::weakly_canonical(fs::path(decoder)).parent_path() == fs::weakly_canonical(fs::path(out))) {
    const double bytes = double(fs::file_size(decoder, ec));
    storage += bytes;
    metrics["decoder_mb"] = bytes / (1 << 20);
  }
  metrics["storage_mb"] = storage / (1 << 20);
  write_latent_run_metrics(out, o, run.config, field_file, metrics);
  return metrics;
}

}  // namespace lrf
