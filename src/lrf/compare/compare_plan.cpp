#include "lrf/compare/compare_plan.h"

#include "lrf/nerf/nerf_run.h"

namespace lrf {

std::string compare_method_plan(const std::string& method, const CompareOptions& o) {
  const std::string latent_steps = std::to_string(o.latent_iters > 0 ? o.latent_iters : o.iters);
  const std::string scored = ", then scored on the test views";
  if (method == "rgb" || method == "rgb-mip" || method == "rgb/8" || method == "rgb/8-mip") {
    const bool eighth = method.rfind("rgb/8", 0) == 0;
    const bool mip = method.size() > 4 && method.compare(method.size() - 4, 4, "-mip") == 0;
    return std::string("an RGB field on the views") + (eighth ? " reduced 8x" : " at full resolution") +
           (mip ? " with Mip-Splatting's filters" : "") + ", " + std::to_string(o.iters) + " steps" + scored;
  }
  if (method == "latent")
    return "a latent field on the " + o.autoencoder + " latents of the views, " + latent_steps + " steps" + scored;
  if (method == "latent-refined")
    return "the latent field (" + latent_steps + " steps, unless already made) refined through the decoder for " +
           (o.refine.steps > 0 ? std::to_string(o.refine.steps) + " steps"
                               : std::to_string(kRefineStepsPerView) + " steps per training view") +
           scored;
  if (method == "latent-nerf")
    return "a hash-grid NeRF on the latents, " +
           std::to_string(o.nerf_iters > 0 ? o.nerf_iters : nerf::kDefaultNerfIters) + " steps" + scored;
  if (method == "feature-gs")
    return "a feature field lifted to the latents by a 1x1 convolution, " + latent_steps + " steps" + scored;
  return method;
}

}  // namespace lrf
