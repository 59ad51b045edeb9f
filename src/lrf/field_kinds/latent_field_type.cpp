// Latent Gaussian fields (Stage II), feature fields lifted to the latent, and refined fields: rendered at
// latent resolution and decoded, by the decoder a refined field was fitted through unless told otherwise.
#include "lrf/field_kinds/latent_field_type.h"

#include <filesystem>

#include "lrf/core/error.h"
#include "lrf/core/option_parts.h"
#include "lrf/core/run_info.h"
#include "lrf/field_kinds/view_renders.h"
#include "lrf/latent/latent_run.h"
#include "lrf/latent/latent_train_run.h"
#include "lrf/splat/run/train_run.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {

// A latent (or feature) field's recorded request: every setting from OUT/config.json except the ones
// given on this command line among --steps, --checkpoint-every and --cache-dir (which only says where
// encoded views are kept).
FieldTrainRequest recorded_request(const ResumeRequest& request) {
  const FieldTrainRequest& given = request.given;
  const std::string path = (fs::path(given.out) / "config.json").string();
  auto stored = read_json_file(path);
  if (stored.contains("refine")) fail(path, "this folder holds a refined field: continue it with `lrf refine --resume`");
  FieldTrainRequest o = given;
  try {
    const auto& j = stored.at("options");
    o.scene = j.at("scene").get<std::string>();
    o.space = field_kind_name(field_kind_of_config(stored, path));
    o.scene_options.images_dir = j.at("images").get<std::string>();
    o.scene_options.downscale = j.at("downscale").get<int>();
    o.scene_options.test_every = j.at("test_every").get<int>();
    o.scene_options.train_views = j.value("train_views", 0);
    o.sh_degree = j.at("sh_degree").get<int>();
    o.sh_degree_set = true;
    o.seed = j.at("seed").get<uint64_t>();
    o.max_gaussians = j.at("max_gaussians").get<int64_t>();
    o.densify_grad = j.value("densify_grad", splat::DensifyOptions{}.grad_threshold);  // runs before the option
    o.sparse_adam = j.at("sparse_adam").get<bool>();
    o.preset = j.value("preset", std::string(kDefaultPreset));  // runs from before presets had none
    require_recorded_preset(request, o.preset, path);
    if (!request.iters_given) o.iters = j.at("iters").get<int64_t>();
    if (!request.checkpoint_given) o.checkpoint_every = j.at("checkpoint_every").get<int64_t>();
    o.autoencoder = j.at("autoencoder").get<std::string>();
    o.encoder = j.at("encoder").get<std::string>();
    o.init = j.at("init").get<std::string>();
    o.rgb_guide = j.value("rgb_guide", 0.0);
    o.feature_dim = j.value("feature_dim", 0);
    o.inria_rates = !j.value("short_run_rates", false);  // runs from before the short-run rates kept Inria's
  } catch (const nlohmann::json::exception& e) {
    fail(path, std::string("cannot resume: missing or bad options: ") + e.what());
  }
  // Where the initial points came from (recorded by every run since they could be chosen): the resumed
  // run builds the same starting field before its checkpoint replaces it, and records the same origin.
  if (stored.contains("init_points") && stored["init_points"].is_object()) {
    o.init_points.mode = stored["init_points"].value("mode", std::string("auto"));
    if (stored["init_points"].contains("far_shell")) {
      o.init_points.shell.points = stored["init_points"]["far_shell"].value("lattice_points", 0);
      o.init_points.shell.radius_factor = stored["init_points"]["far_shell"].value("radius_factor", 2.0);
    }
  }
  o.scene = resumed_scene_root(given, stored, path, o.scene_options, o.scene);
  return o;
}

class LatentFieldType : public FieldType {
 public:
  FieldKind kind() const override { return FieldKind::latent; }
  bool decoded() const override { return true; }

  void train(const FieldTrainRequest& o) const override {
    const InitPointsOptions points = train_points(o);
    refuse_rgb_settings(o);
    refuse_nerf_settings(o);
    // A negative count is compare's "half the latent channels", met here only in a run being resumed.
    if (o.feature_dim < 0 && !o.resume) fail_usage("--feature-dim must be 0 (a latent field) or a feature count");
    // --test-list and --format are refused by the job itself (require_latent_scene_options).
    if (o.scene_options.crop_to_multiple_of_8)
      fail_usage("--crop8 does not apply to --space latent: latent views are always cropped to multiples of 8");
    LatentTrainOptions l;
    copy_part<splat::GaussianFitOptions>(l, o);
    copy_part<LatentSource>(l, o);
    copy_part<LatentFitSettings>(l, o);
    l.init_points = points;
    l.sh_degree = o.sh_degree_set ? o.sh_degree : kDefaultLatentShDegree;
    l.short_run_rates = !o.inria_rates;
    if (o.mip) fail_usage("--mip applies to RGB fields (the paper's Mip-Splatting/8 baseline)");
    train_latent_field(l);
  }

  void resume(const ResumeRequest& request) const override { train(recorded_request(request)); }
  std::string checkpoint_path(const std::string& run) const override { return splat::checkpoint_path(run); }
  bool finished(const std::string& run) const override { return splat::run_finished(run); }

  std::unique_ptr<FieldFrames> frames(const std::string& run, const std::string& decoder) const override {
    return latent_field_frames(run, decoder);
  }

  nlohmann::json evaluate(const std::string& run, const FieldScoring& scoring) const override {
    return evaluate_latent_run(run, decoded_eval_options(scoring));
  }

  int render_views(const std::string& run, const ViewRenders& request) const override {
    const LatentRun field = open_latent_run(run);
    return write_decoded_views(
        run, request, field.scene, field.range,
        [&] { return load_autoencoder(field.autoencoder, field.encoder, request.decoder.empty() ? field.decoder : request.decoder); },
        [&](int i) { return render_latent(field, i); });
  }
};

}  // namespace

const FieldType& latent_field_type() {
  static const LatentFieldType type;
  return type;
}

}  // namespace lrf
