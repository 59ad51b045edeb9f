#include "lrf/splat/render_field.h"

#include <algorithm>

namespace lrf::splat {

RasterSettings field_settings(const Camera& camera, int channels, const FieldRenderOptions& options) {
  auto background = options.background.defined() ? options.background : torch::zeros({channels}, torch::kFloat32);
  auto s = settings_for(camera, options.sh_degree, background);
  if (options.mip) {
    s.mip_2d_filter = true;
    s.dilation = 0.1;  // Mip-Splatting's 2D filter variance (pixels^2)
  }
  return s;
}

RenderOutput render_field(const Gaussians& g, const Camera& camera, const FieldRenderOptions& options) {
  torch::NoGradGuard no_grad;
  FieldRenderOptions o = options;
  o.sh_degree = std::min(o.sh_degree, g.max_sh_degree);
  auto s = field_settings(camera, g.channels(), o);
  return render(g.means.detach(), g.log_scales.detach(), g.quats.detach(), g.opacity_logits.detach(),
                g.sh.detach(), s);
}

}  // namespace lrf::splat
