#include "lrf/compare/compare_plan.h"

#include "lrf/compare/compare_methods.h"
#include "lrf/nerf/nerf_run.h"
#include "lrf/nerf/nerf_train_run.h"

namespace lrf {

std::string compare_method_plan(const std::string& method, const CompareOptions& o) {
  const std::string latent_steps = std::to_string(o.latent_iters > 0 ? o.latent_iters : o.iters);
  const std::string scored = ", then scored on the test views";
  const CompareMethod& m = compare_method(method);
  switch (m.job) {
    case CompareJob::rgb_field:
      return std::string("an RGB field on the views") +
             (m.rgb_factor == 1 ? " at full resolution" : " reduced " + std::to_string(m.rgb_factor) + "x") +
             (m.mip ? " with Mip-Splatting's filters" : "") + ", " + std::to_string(o.iters) + " steps" + scored;
    case CompareJob::latent_field:
      return "a latent field on the " + o.autoencoder + " latents of the views, " + latent_steps + " steps" + scored;
    case CompareJob::refined_latent:
      return "the latent field (" + latent_steps + " steps, unless already made) refined through the decoder for " +
           refine_length_text(o.refine) + scored;
    case CompareJob::latent_nerf:
      return "a hash-grid NeRF on the latents, " +
           std::to_string(o.nerf_iters > 0 ? o.nerf_iters : nerf::kDefaultNerfIters) + " steps" + scored;
    case CompareJob::feature_field:
      return "a feature field lifted to the latents by a 1x1 convolution, " + latent_steps + " steps" + scored;
  }
  return method;
}

}  // namespace lrf
