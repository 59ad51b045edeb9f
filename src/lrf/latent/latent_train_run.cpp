#include "lrf/latent/latent_train_run.h"

#include <filesystem>
#include <memory>

#include <torch/torch.h>

#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/progress.h"
#include "lrf/core/resources.h"
#include "lrf/core/run_info.h"
#include "lrf/core/training_steps.h"
#include "lrf/feature/feature_training.h"
#include "lrf/latent/encoded_scene.h"
#include "lrf/latent/latent_field.h"
#include "lrf/latent/latent_run.h"
#include "lrf/splat/run/field_kind.h"
#include "lrf/splat/run/run_folder.h"
#include "lrf/splat/run/train_run.h"

namespace fs = std::filesystem;

namespace lrf {

namespace {
nlohmann::json options_json(const LatentTrainOptions& o) {
  nlohmann::json j = splat::fit_options_json(o);
  j.update({{"autoencoder", o.autoencoder}, {"encoder", o.encoder}, {"init", o.init}, {"feature_dim", o.feature_dim},
            {"rgb_guide", o.rgb_guide}, {"short_run_rates", o.short_run_rates}});
  return j;
}
}  // namespace

LatentTrainResult train_latent_field(const LatentTrainOptions& o) {
  using namespace lrf::splat;
  const Stopwatch preparing;
  if (o.sh_degree < 0 || o.sh_degree > 3) fail_usage("--sh-degree must be 0..3");
  check_training_steps(o.iters);
  if (!(o.densify_grad > 0)) fail_usage("--densify-grad must be positive");
  if (!(o.rgb_guide >= 0)) fail_usage("--rgb-guide must be 0 (off) or a positive weight");
  require_latent_scene_options(o.scene_options, "latent");
  LatentInit init = parse_latent_init(o.init);
  if (o.feature_dim != 0 && o.feature_dim != kHalfLatentChannels && (o.feature_dim < 1 || o.feature_dim > kMaxFeatureDim))
    fail_usage("--feature-dim must be 1.." + std::to_string(kMaxFeatureDim) + ", got " + std::to_string(o.feature_dim));
  if (o.feature_dim != 0 && init != LatentInit::latents)
    fail_usage("--init rgb chooses latent features; a feature field (--feature-dim) starts from constant features");
  const auto lock = splat::prepare_output_dir(o.out, o.force, o.resume);

  EncodedScene encoded = load_encoded_scene({o.scene, o.scene_options, o.autoencoder, o.encoder, o.cache_dir});
  const SceneOptions& so = encoded.options;
  const Scene& scene = encoded.scene;
  auto& ae = encoded.autoencoder;
  const std::string& ae_id = encoded.autoencoder_identity;
  const double encode_seconds = encoded.encode_seconds;
  LatentTrainingData data = prepare_latent_training(scene, encoded.latents, init, o.sh_degree, o.seed,
                                                    o.init_points, o.rgb_guide);
  const int channels = ae->latent_channels();
  const int feature_dim = o.feature_dim == kHalfLatentChannels ? default_feature_dim(channels) : o.feature_dim;
  std::unique_ptr<FeatureLiftTraining> lift;  // a feature field's lift (feature-gs), trained with it
  if (feature_dim > 0 && o.rgb_guide > 0) fail_usage("--rgb-guide does not apply to feature fields (--feature-dim)");
  if (feature_dim > 0) {
    data.init = feature_field_start(data.init, feature_dim);
    data.init_description += "; as a feature field: " + std::to_string(feature_dim) +
                             " features per Gaussian at 0.5, lifted to " + std::to_string(channels) +
                             " latent channels by a 1x1 convolution";
    lift = std::make_unique<FeatureLiftTraining>(FeatureLift::initial(feature_dim, channels, o.seed + 2),
                                                 kLiftLearningRate, o.out, o.checkpoint_every, o.iters);
    if (!o.resume) lift->remove_checkpoints();
  }
  log_info("initial field: " + data.init_description);

  TrainerOptions to = trainer_options(o);
  to.lr = o.short_run_rates ? LearningRates{}.for_short_run(o.iters) : LearningRates{};
  to.background = torch::zeros({feature_dim > 0 ? feature_dim : data.init.channels()});
  const double extent = scene.camera_extent();
  if (lift) {
    std::vector<torch::Tensor> targets;
    for (const auto& v : data.views) targets.push_back(v.target);
    lift->attach(to, std::move(targets), to.lambda_ssim);
  }

  auto config = run_record(options_json(o));
  config.update(scene_config(o.scene, so, scene, o.out));
  config["space"] = field_kind_name(FieldKind::latent);
  config["sh_degree"] = o.sh_degree;
  config["mip"] = false;
  config["background"] = std::vector<float>(static_cast<size_t>(feature_dim > 0 ? feature_dim : channels), 0.0f);
  config["extent"] = extent;
  config["autoencoder"] = o.autoencoder;
  config["encoder"] = o.encoder;
  config["autoencoder_identity"] = ae_id;
  config["latent_channels"] = ae->latent_channels();
  config["latent_range"] = data.range.to_json();
  config["init"] = o.init;
  config["rgb_guide"] = o.rgb_guide;
  config["init_points"] = data.init_points;
  config["learning_rates"] = {{"position_init", to.lr.position_init}, {"position_final", to.lr.position_final},
                              {"sh_dc", to.lr.sh_dc}, {"sh_rest", to.lr.sh_rest}, {"scales", to.lr.scales},
                              {"rotations", to.lr.rotations}, {"opacity", to.lr.opacity}};
  if (feature_dim > 0) {
    config["feature_dim"] = feature_dim;
    config["feature_field"] = {{"lift", "lift.safetensors"},
                               {"feature_lr", kFeatureLearningRate},
                               {"lift_lr", kLiftLearningRate},
                               {"feature_init", 0.5},
                               {"lift_init", "uniform +-1/sqrt(feature_dim), PyTorch's Conv2d default"},
                               {"loss", "(1 - 0.2) L1 + 0.2 (1 - SSIM) of the lifted render and the normalised latent"}};
  }
  const std::string config_path = (fs::path(o.out) / "config.json").string();
  write_json_file(config_path, config);

  Trainer trainer(std::move(data.views), std::move(data.init), extent, to);
  RunOptions ro(o);
  ro.task = feature_dim > 0 ? "train-feature" : "train-latent";
  if (lift) lift->attach(ro, trainer);
  if (o.rgb_guide > 0) {
    ro.exported = [channels](splat::Gaussians g) {
      g.sh = g.sh.narrow(2, 0, channels).contiguous();
      return g;
    };
  }
  ro.prepared_seconds = preparing.seconds();
  auto summary = run_training(trainer, ro);
  config["result"] = {{"steps", summary.steps}, {"gaussians", summary.gaussians}, {"seconds", summary.seconds},
                      {"encode_seconds", encode_seconds}, {"final_loss", summary.last_loss},
                      {"peak_memory_mb", peak_memory_mb()}};
  write_json_file(config_path, config);
  log_info("wrote " + o.out + "/point_cloud.ply: " + std::to_string(summary.gaussians) +
           (feature_dim > 0 ? " feature Gaussians (and lift.safetensors)" : " latent Gaussians") + " after " +
           std::to_string(summary.steps) + " steps in " + Progress::format_duration(summary.seconds));
  return {summary.steps, summary.gaussians, summary.seconds, encode_seconds};
}

}  // namespace lrf
