// Latent NeRFs (the paper's Latent-NeRF* baseline): the same normalised latents as a latent field, rendered
// ray by ray and decoded through the autoencoder's decoder unless told otherwise.
#include "lrf/field_kinds/nerf_field_type.h"

#include <filesystem>

#include "lrf/core/error.h"
#include "lrf/core/option_parts.h"
#include "lrf/field_kinds/view_renders.h"
#include "lrf/nerf/nerf_run.h"
#include "lrf/nerf/nerf_train_run.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {

class NerfFieldType : public FieldType {
 public:
  FieldKind kind() const override { return FieldKind::latent_nerf; }
  bool decoded() const override { return true; }

  void train(const FieldTrainRequest& o) const override {
    const InitPointsOptions points = train_points(o);
    refuse_latent_settings(o);
    refuse_rgb_settings(o);
    if (o.mip || o.sh_degree_set || o.max_gaussians || o.sparse_adam || o.white_background || o.init != "latents" ||
        o.densify_grad != splat::DensifyOptions{}.grad_threshold)
      fail_usage("--mip, --sh-degree, --max-gaussians, --densify-grad, --sparse-adam, --white-background and --init "
                 "apply to Gaussian fields, not to --space latent-nerf");
    if (o.scene_options.crop_to_multiple_of_8)
      fail_usage("--crop8 does not apply to --space latent-nerf: latent views are always cropped to multiples of 8");
    nerf::LatentNerfOptions n;
    copy_part<SceneFitOptions>(n, o);
    copy_part<LatentSource>(n, o);
    copy_part<nerf::NerfFitSettings>(n, o);
    n.iters = o.iters_set ? o.iters : nerf::kDefaultNerfIters;
    n.init_points = points;
    nerf::train_latent_nerf(n);
  }

  // The recorded options, except --steps, --checkpoint-every and --cache-dir when given.
  void resume(const ResumeRequest& request) const override {
    const FieldTrainRequest& given = request.given;
    if (given.nerf_option_set)
      fail_usage("--rays, --samples and --hash-log2 are fixed when a latent NeRF starts; --resume keeps the recorded ones");
    nerf::LatentNerfOptions n = nerf::recorded_nerf_options(given.out);
    require_recorded_preset(request, n.preset, (fs::path(given.out) / "config.json").string());
    n.resume = true;
    if (request.iters_given) n.iters = given.iters;
    if (request.checkpoint_given) n.checkpoint_every = given.checkpoint_every;
    if (!given.cache_dir.empty()) n.cache_dir = given.cache_dir;
    nerf::train_latent_nerf(n);
  }
  std::string checkpoint_path(const std::string& run) const override { return nerf::nerf_checkpoint_path(run); }
  bool finished(const std::string& run) const override { return nerf::nerf_run_finished(run); }

  std::unique_ptr<FieldFrames> frames(const std::string& run, const std::string& decoder) const override {
    return nerf_field_frames(run, decoder);
  }

  nlohmann::json evaluate(const std::string& run, const FieldScoring& scoring) const override {
    return nerf::evaluate_nerf_run(run, decoded_eval_options(scoring));
  }

  int render_views(const std::string& run, const ViewRenders& request) const override {
    const nerf::NerfRun field = nerf::open_nerf_run(run);
    return write_decoded_views(
        run, request, field.scene, field.range,
        [&] { return load_autoencoder(field.autoencoder, field.encoder, request.decoder); },
        [&](int i) { return nerf::render_nerf_latent(field, i); });
  }
};

}  // namespace

const FieldType& nerf_field_type() {
  static const NerfFieldType type;
  return type;
}

}  // namespace lrf
