// RGB Gaussian fields (lrf train --space rgb, compare's rgb rows): rendered directly, at any resolution.
#include "lrf/field_kinds/rgb_field_type.h"

#include <filesystem>

#include "lrf/core/error.h"
#include "lrf/core/option_parts.h"
#include "lrf/core/run_info.h"
#include "lrf/core/image_io.h"
#include "lrf/core/log.h"
#include "lrf/core/progress.h"
#include "lrf/field_kinds/view_renders.h"
#include "lrf/rgb/rgb_eval.h"
#include "lrf/rgb/rgb_field.h"
#include "lrf/rgb/rgb_train_run.h"
#include "lrf/splat/render_field.h"
#include "lrf/splat/run/run_folder.h"
#include "lrf/splat/run/train_run.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {

RgbTrainOptions rgb_options(const FieldTrainRequest& o, const InitPointsOptions& points) {
  RgbTrainOptions r;
  copy_part<splat::GaussianFitOptions>(r, o);
  copy_part<RgbFitSettings>(r, o);
  r.init_points = points;
  return r;
}

class RgbFieldType : public FieldType {
 public:
  FieldKind kind() const override { return FieldKind::rgb; }
  bool decoded() const override { return false; }

  void train(const FieldTrainRequest& o) const override {
    const InitPointsOptions points = train_points(o);
    refuse_latent_settings(o);
    refuse_nerf_settings(o);
    if (o.feature_dim != 0) fail_usage("--feature-dim applies to --space latent (a feature field lifted to the latent)");
    train_rgb_field(rgb_options(o, points));
  }

  // The recorded options, except --steps and --checkpoint-every when given, and --cache-dir (where
  // triangulated points are cached). An RGB field of lrf train, compare or pipeline: one job trains them all.
  void resume(const ResumeRequest& request) const override {
    const FieldTrainRequest& given = request.given;
    const std::string path = (fs::path(given.out) / "config.json").string();
    const nlohmann::json stored = read_json_file(path);
    RgbTrainOptions r = recorded_rgb_options(given.out, stored);
    require_recorded_preset(request, r.preset, path);
    if (request.iters_given) r.iters = given.iters;
    if (request.checkpoint_given) r.checkpoint_every = given.checkpoint_every;
    r.init_points.cache_dir = given.init_points.cache_dir.empty() ? given.cache_dir : given.init_points.cache_dir;
    r.scene = resumed_scene_root(given, stored, path, r.scene_options, r.scene);
    train_rgb_field(r);
  }
  std::string checkpoint_path(const std::string& run) const override { return splat::checkpoint_path(run); }
  bool finished(const std::string& run) const override { return splat::run_finished(run); }

  std::unique_ptr<FieldFrames> frames(const std::string& run, const std::string& decoder) const override {
    if (!decoder.empty()) fail(run, "--decoder applies to latent fields; this is an RGB field");
    return rgb_field_frames(run);
  }

  nlohmann::json evaluate(const std::string& run, const FieldScoring& scoring) const override {
    if (!scoring.decoder.empty()) fail_usage("--decoder applies to latent fields and latent NeRFs");
    RgbEvalOptions e;
    e.lpips_weights = scoring.lpips_weights;
    e.scale = scoring.scale;
    return evaluate_rgb_run(run, e);
  }

  int render_views(const std::string& run, const ViewRenders& request) const override {
    if (!request.decoder.empty()) fail_usage("--decoder applies to latent fields");
    const splat::FieldRun field = splat::open_field_run(run);
    const std::vector<int> views = split_views(field.scene, request.split, run);
    // Every view's size is checked before anything is written.
    std::vector<Camera> cameras;
    for (int i : views)
      cameras.push_back(splat::scaled_camera(field.scene.views[static_cast<size_t>(i)].camera, request.scale,
                                             request.width, request.height));
    const std::string dir = renders_folder(run, request, field.scene);
    Progress progress("render", static_cast<long>(views.size()));
    long done = 0;
    for (size_t k = 0; k < views.size(); ++k) {
      const auto& view = field.scene.views[static_cast<size_t>(views[k])];
      auto image = splat::render_field(field.field, cameras[k], field.render).image;
      write_image_rgb((fs::path(dir) / (fs::path(view.name).stem().string() + ".png")).string(),
                      splat::tensor_to_image(image));
      progress.update(++done);
    }
    progress.finish();
    log_info("wrote " + std::to_string(views.size()) + " images to " + dir);
    return static_cast<int>(views.size());
  }
};

}  // namespace

const FieldType& rgb_field_type() {
  static const RgbFieldType type;
  return type;
}

}  // namespace lrf
