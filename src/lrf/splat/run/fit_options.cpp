#include "lrf/splat/run/fit_options.h"

#include "lrf/splat/train/trainer.h"

namespace lrf::splat {

TrainerOptions trainer_options(const GaussianFitOptions& o) {
  TrainerOptions to;
  to.iterations = o.iters;
  to.sh_degree = o.sh_degree;
  to.seed = o.seed;
  to.sparse_adam = o.sparse_adam;
  to.schedule = DensifySchedule::for_iterations(o.iters);
  to.densify.max_gaussians = o.max_gaussians;
  to.densify.grad_threshold = o.densify_grad;
  return to;
}

nlohmann::json fit_options_json(const GaussianFitOptions& o) {
  const SceneOptions& so = o.scene_options;
  return {{"scene", o.scene},
          {"out", o.out},
          {"images", so.images_dir},
          {"downscale", so.downscale},
          {"test_every", so.test_every},
          {"train_views", so.train_views},
          {"iters", o.iters},
          {"sh_degree", o.sh_degree},
          {"seed", o.seed},
          {"max_gaussians", o.max_gaussians},
          {"densify_grad", o.densify_grad},
          {"checkpoint_every", o.checkpoint_every},
          {"sparse_adam", o.sparse_adam},
          {"preset", o.preset},
          {"resume", o.resume},
          {"force", o.force}};
}

}  // namespace lrf::splat
