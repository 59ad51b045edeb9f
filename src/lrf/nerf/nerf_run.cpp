// Reopening a latent NeRF run: rendering its views and scoring the decoded test views (see nerf_run.h).
#include "lrf/nerf/nerf_run.h"

#include <filesystem>

#include <torch/torch.h>

#include "lrf/core/error.h"
#include "lrf/core/run_info.h"
#include "lrf/latent/latent_field.h"
#include "lrf/latent/latent_scoring.h"
#include "lrf/latent/trained_run_checks.h"
#include "lrf/nerf/nerf_render.h"
#include "lrf/splat/run/field_kind.h"
#include "lrf/scene/run_scene_location.h"
#include "lrf/splat/run/run_config.h"
#include "lrf/splat/run/run_folder.h"

namespace fs = std::filesystem;

namespace lrf::nerf {

std::string nerf_field_path(const std::string& out) { return (fs::path(out) / "field.safetensors").string(); }
std::string nerf_checkpoint_path(const std::string& out) { return (fs::path(out) / "checkpoint.safetensors").string(); }

bool nerf_run_finished(const std::string& out) {
  const fs::path config = fs::path(out) / "config.json";
  if (!fs::exists(config) || !fs::exists(nerf_field_path(out))) return false;
  return read_json_file(config.string()).contains("result");
}

NerfRun open_nerf_run(const std::string& out) {
  NerfRun run;
  run.out = out;
  const std::string config_path = (fs::path(out) / "config.json").string();
  run.config = splat::read_run_config(out);
  if (field_kind_of_config(run.config, config_path) != FieldKind::latent_nerf)
    fail(config_path, "not a latent NeRF run (lrf train --space latent-nerf)");
  std::string identity;
  std::vector<int> resolution;
  try {
    run.autoencoder = run.config.at("autoencoder").get<std::string>();
    run.encoder = run.config.value("encoder", std::string());
    identity = run.config.at("autoencoder_identity").get<std::string>();
    run.range = LatentRange::from_json(run.config.at("latent_range"), config_path);
    resolution = run.config.at("resolution").get<std::vector<int>>();
  } catch (const nlohmann::json::exception& e) {
    fail(config_path, std::string("missing or bad latent NeRF settings: ") + e.what());
  }
  check_autoencoder_unchanged(run.autoencoder, run.encoder, identity, config_path);
  const std::string scene_root = run_scene_root(run.config, config_path);
  run.scene = reload_trained_scene(scene_root, splat::scene_options_from_config(run.config, config_path), resolution,
                                   config_path);
  check_run_scene_views(run.scene, run.config, config_path);
  run.config["scene"] = scene_root;
  const std::string field = nerf_field_path(out);
  if (!fs::exists(field)) fail(field, "not found: the run has not reached its first checkpoint (resume it with lrf train --resume)");
  run.field = NerfField::load(field);
  if (run.field.spec.channels != run.range.channels())
    fail(field, "the field renders " + std::to_string(run.field.spec.channels) + " channels, the run's latent range has " +
                    std::to_string(run.range.channels()));
  return run;
}

torch::Tensor render_nerf_latent(const NerfRun& run, int view) {
  return render_view(run.field, latent_camera(run.scene.views.at(static_cast<size_t>(view)).camera));
}

nlohmann::json evaluate_nerf_run(const std::string& out, const LatentEvalOptions& o) {
  const NerfRun run = open_nerf_run(out);
  nlohmann::json metrics = score_latent_run(out, run.scene, run.range, run.autoencoder, run.encoder, o.decoder, o,
                                            [&](int view) { return render_nerf_latent(run, view); });
  metrics["parameters"] = run.field.parameter_count();
  const std::string field_file = nerf_field_path(out);
  std::error_code ec;
  metrics["storage_mb"] = double(fs::file_size(field_file, ec)) / (1 << 20);
  write_latent_run_metrics(out, o, run.config, field_file, metrics);
  return metrics;
}

}  // namespace lrf::nerf
