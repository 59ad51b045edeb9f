// The torch autograd Function that ties projection, SH, binning and compositing together.
#include <omp.h>

#include <cmath>
#include <cstring>
#include <memory>

#include "lrf/core/error.h"
#include "lrf/splat/raster/binning.h"
#include "lrf/splat/raster/projection.h"
#include "lrf/splat/raster/raster_kernels.h"
#include "lrf/splat/raster/rasterize.h"
#include "lrf/splat/raster/sh.h"

namespace lrf::splat {
namespace {

using torch::autograd::AutogradContext;
using torch::autograd::variable_list;

// A tensor that owns a std::vector's buffer, without copying it. An empty vector has no buffer, and
// libtorch never calls the deleter of a null data pointer (LeakSanitizer caught the vector leaking).
torch::Tensor adopt(std::vector<int32_t>&& v) {
  if (v.empty()) return torch::empty({0}, torch::kInt32);
  auto* owned = new std::vector<int32_t>(std::move(v));
  const int64_t size = static_cast<int64_t>(owned->size());
  return torch::from_blob(owned->data(), {size}, [owned](void*) { delete owned; }, torch::kInt32);
}

Viewpoint viewpoint_of(const RasterSettings& s) {
  Viewpoint v;
  v.width = s.width;
  v.height = s.height;
  v.fx = s.fx, v.fy = s.fy, v.cx = s.cx, v.cy = s.cy;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) v.R[3 * r + c] = s.R(r, c);
    v.t[r] = s.t(r);
  }
  const Eigen::Vector3d centre = -s.R.transpose() * s.t;
  for (int r = 0; r < 3; ++r) v.campos[r] = centre(r);
  v.near = s.near;
  v.dilation = s.dilation;
  v.mip_2d_filter = s.mip_2d_filter;
  return v;
}

// Viewpoint is plain data: it rides in the autograd context as raw bytes.
torch::Tensor pack(const Viewpoint& v) {
  auto t = torch::empty({static_cast<int64_t>(sizeof(Viewpoint))}, torch::kUInt8);
  std::memcpy(t.data_ptr<uint8_t>(), &v, sizeof(Viewpoint));
  return t;
}
Viewpoint unpack(const torch::Tensor& t) {
  Viewpoint v;
  std::memcpy(&v, t.data_ptr<uint8_t>(), sizeof(Viewpoint));
  return v;
}

RasterInputs raster_inputs(const Viewpoint& v, int channels, const torch::Tensor& xy, const torch::Tensor& conic,
                           const torch::Tensor& opacity, const torch::Tensor& extent, const torch::Tensor& depth,
                           const torch::Tensor& colors, const torch::Tensor& background,
                           const torch::Tensor& offsets, const torch::Tensor& ids) {
  RasterInputs in;
  in.width = v.width;
  in.height = v.height;
  in.tiles_x = v.tiles_x();
  in.tiles_y = v.tiles_y();
  in.channels = channels;
  in.xy = xy.data_ptr<float>();
  in.conic = conic.data_ptr<float>();
  in.opacity = opacity.data_ptr<float>();
  in.extent = extent.data_ptr<float>();
  in.depth = depth.data_ptr<float>();
  in.colors = colors.data_ptr<float>();
  in.background = background.data_ptr<float>();
  in.tile_offsets = offsets.data_ptr<int32_t>();
  in.tile_ids = ids.data_ptr<int32_t>();
  return in;
}

struct ShContext {
  int k_stored, channels, degree;
  const float* sh;
  const float* means;
  const double* campos;
};

void evaluate_color(const void* ctx, int64_t g, float* out) {
  const auto* c = static_cast<const ShContext*>(ctx);
  sh_forward_one(g, c->k_stored, c->channels, c->degree, c->sh, c->means, c->campos, out);
}

class RenderFunction : public torch::autograd::Function<RenderFunction> {
 public:
  // means2d is a leaf created by render(): the forward writes the projected means into it and the backward
  // returns the screen-space gradient for it. radii_out receives the (non-differentiable) radii.
  static variable_list forward(AutogradContext* ctx, torch::Tensor means, torch::Tensor log_scales,
                               torch::Tensor quats, torch::Tensor opacity_logits, torch::Tensor sh,
                               torch::Tensor means2d, const RasterSettings& s, torch::Tensor background,
                               torch::Tensor* radii_out) {
    const Viewpoint v = viewpoint_of(s);
    const int64_t n = means.size(0);
    const int k_stored = static_cast<int>(sh.size(1)), C = static_cast<int>(sh.size(2));
    const auto f32 = torch::TensorOptions().dtype(torch::kFloat32);
    auto depth = torch::empty({n}, f32), conic = torch::empty({n, 3}, f32), opacity = torch::empty({n}, f32);
    auto extent = torch::empty({n, 2}, f32), colors = torch::empty({n, C}, f32);
    auto radii = torch::empty({n}, torch::kInt32), rect = torch::empty({n, 4}, torch::kInt32);
    project_forward(n, means.data_ptr<float>(), log_scales.data_ptr<float>(), quats.data_ptr<float>(),
                    opacity_logits.data_ptr<float>(), v,
                    {means2d.data_ptr<float>(), depth.data_ptr<float>(), conic.data_ptr<float>(),
                     opacity.data_ptr<float>(), extent.data_ptr<float>(), radii.data_ptr<int32_t>(),
                     rect.data_ptr<int32_t>()});
    // Colours are evaluated by the rasterizer when a splat is first blended (see ColorSource).
    auto color_state = torch::zeros({n}, torch::kUInt8);
    const ShContext sh_ctx{k_stored, C, s.sh_degree, sh.data_ptr<float>(), means.data_ptr<float>(), v.campos};
    ColorSource source{colors.data_ptr<float>(), color_state.data_ptr<uint8_t>(), &evaluate_color, &sh_ctx};
    source.rows = reinterpret_cast<const char*>(sh.data_ptr<float>());
    source.row_stride = static_cast<int64_t>(sizeof(float)) * k_stored * C;
    source.row_bytes = static_cast<int64_t>(sizeof(float)) * (s.sh_degree + 1) * (s.sh_degree + 1) * C;
    source.point = means.data_ptr<float>();
    TileBins bins = bin_gaussians(n, depth.data_ptr<float>(), rect.data_ptr<int32_t>(), v.tiles_x(), v.tiles_y());
    auto offsets = adopt(std::move(bins.offsets)), ids = adopt(std::move(bins.ids));

    const int64_t H = v.height, W = v.width;
    auto image = torch::empty({C, H, W}, f32), alpha = torch::empty({1, H, W}, f32);
    auto depth_img = torch::empty({1, H, W}, f32), t_final = torch::empty({H, W}, f32);
    auto last = torch::empty({H, W}, torch::kInt32);
    rasterize_forward(raster_inputs(v, C, means2d, conic, opacity, extent, depth, colors, background, offsets, ids),
                      source, {image.data_ptr<float>(), alpha.data_ptr<float>(), depth_img.data_ptr<float>(),
                       t_final.data_ptr<float>(), last.data_ptr<int32_t>()});

    ctx->save_for_backward({means, log_scales, quats, opacity_logits, sh, means2d});
    auto& d = ctx->saved_data;
    d["view"] = pack(v);
    d["sh_degree"] = static_cast<int64_t>(s.sh_degree);
    d["sh_gradient_sink"] = static_cast<int64_t>(reinterpret_cast<intptr_t>(s.sh_gradient_sink));
    d["background"] = background;
    d["depth"] = depth;
    d["conic"] = conic;
    d["opacity"] = opacity;
    d["extent"] = extent;
    d["colors"] = colors;
    d["color_state"] = color_state;
    d["radii"] = radii;
    d["offsets"] = offsets;
    d["ids"] = ids;
    d["t_final"] = t_final;
    d["last"] = last;
    ctx->set_materialize_grads(false);
    *radii_out = radii;
    return {image, alpha, depth_img};
  }

  static variable_list backward(AutogradContext* ctx, variable_list grads) {
    const auto saved = ctx->get_saved_variables();
    const auto &means = saved[0], &log_scales = saved[1], &quats = saved[2], &opacity_logits = saved[3],
               &sh = saved[4], &means2d = saved[5];
    auto& d = ctx->saved_data;
    const Viewpoint v = unpack(d["view"].toTensor());
    const int degree = static_cast<int>(d["sh_degree"].toInt());
    const auto* sink = reinterpret_cast<const ShGradientSink*>(static_cast<intptr_t>(d["sh_gradient_sink"].toInt()));
    const int64_t n = means.size(0);
    const int k_stored = static_cast<int>(sh.size(1)), C = static_cast<int>(sh.size(2));
    const int64_t H = v.height, W = v.width;
    const auto f32 = torch::TensorOptions().dtype(torch::kFloat32);

    auto grad_or_zeros = [&](const torch::Tensor& g, torch::IntArrayRef shape) {
      return g.defined() ? g.to(torch::kFloat32).contiguous() : torch::zeros(shape, f32);
    };
    const torch::Tensor d_image = grad_or_zeros(grads[0], {C, H, W});
    const torch::Tensor d_alpha = grads[1].defined() ? grads[1].to(torch::kFloat32).contiguous() : torch::Tensor();
    const torch::Tensor d_depth = grads[2].defined() ? grads[2].to(torch::kFloat32).contiguous() : torch::Tensor();

    const torch::Tensor colors = d["colors"].toTensor(), radii = d["radii"].toTensor();
    auto d_xy = torch::empty({n, 2}, f32), d_conic = torch::empty({n, 3}, f32);
    auto d_opacity = torch::empty({n}, f32), d_z = torch::empty({n}, f32), d_colors = torch::empty({n, C}, f32);
    RasterInputs in = raster_inputs(v, C, means2d, d["conic"].toTensor(), d["opacity"].toTensor(),
                                    d["extent"].toTensor(), d["depth"].toTensor(), colors,
                                    d["background"].toTensor(), d["offsets"].toTensor(), d["ids"].toTensor());
    rasterize_backward(n, in,
                       {d["t_final"].toTensor().data_ptr<float>(), d["last"].toTensor().data_ptr<int32_t>(),
                        d_image.data_ptr<float>(), d_alpha.defined() ? d_alpha.data_ptr<float>() : nullptr,
                        d_depth.defined() ? d_depth.data_ptr<float>() : nullptr},
                       {d_xy.data_ptr<float>(), d_conic.data_ptr<float>(), d_opacity.data_ptr<float>(),
                        d_z.data_ptr<float>(), d_colors.data_ptr<float>(), /*colors_only_touched=*/true});

    auto d_means = torch::empty({n, 3}, f32), d_log_scales = torch::empty({n, 3}, f32);
    auto d_quats = torch::empty({n, 4}, f32), d_logits = torch::empty({n, 1}, f32);
    torch::Tensor d_sh;  // stays undefined when a sink takes the rows
    if (!sink) d_sh = torch::empty({n, k_stored, C}, f32);
    project_backward(n, means.data_ptr<float>(), log_scales.data_ptr<float>(), quats.data_ptr<float>(),
                     opacity_logits.data_ptr<float>(), radii.data_ptr<int32_t>(), v,
                     {d_xy.data_ptr<float>(), d_conic.data_ptr<float>(), d_opacity.data_ptr<float>(),
                      d_z.data_ptr<float>()},
                     d_means.data_ptr<float>(), d_log_scales.data_ptr<float>(), d_quats.data_ptr<float>(),
                     d_logits.data_ptr<float>());
    sh_backward(n, k_stored, C, degree, sh.data_ptr<float>(), means.data_ptr<float>(), v.campos,
                radii.data_ptr<int32_t>(), colors.data_ptr<float>(), d_colors.data_ptr<float>(),
                sink ? nullptr : d_sh.data_ptr<float>(), d_means.data_ptr<float>(),
                d["color_state"].toTensor().data_ptr<uint8_t>(), sink);
    // Inria's densification statistic is d loss / d NDC: NDC spans 2 units over W (H) pixels.
    auto d_means2d = d_xy * torch::tensor({0.5f * W, 0.5f * H}, f32);
    return {d_means, d_log_scales, d_quats, d_logits, d_sh, d_means2d, {}, {}, {}};
  }
};

torch::Tensor checked(const torch::Tensor& t, const char* name, std::vector<int64_t> shape) {
  if (!t.defined()) lrf::fail(std::string("render: ") + name + " is undefined");
  if (t.dim() != static_cast<int64_t>(shape.size()))
    lrf::fail(std::string("render: ") + name + " must have " + std::to_string(shape.size()) + " dimensions");
  for (size_t k = 0; k < shape.size(); ++k)
    if (shape[k] >= 0 && t.size(k) != shape[k])
      lrf::fail(std::string("render: ") + name + " has a wrong size in dimension " + std::to_string(k));
  if (t.scalar_type() != torch::kFloat32 || !t.device().is_cpu())
    lrf::fail(std::string("render: ") + name + " must be a float32 CPU tensor");
  return t.contiguous();
}

}  // namespace

RasterSettings settings_for(const lrf::Camera& cam, int sh_degree, torch::Tensor background) {
  RasterSettings s;
  s.width = cam.width;
  s.height = cam.height;
  s.fx = cam.fx, s.fy = cam.fy, s.cx = cam.cx, s.cy = cam.cy;
  s.R = cam.R;
  s.t = cam.t;
  s.sh_degree = sh_degree;
  s.background = std::move(background);
  return s;
}

RenderOutput render(const torch::Tensor& means_in, const torch::Tensor& log_scales_in, const torch::Tensor& quats_in,
                    const torch::Tensor& opacity_logits_in, const torch::Tensor& sh_in, const RasterSettings& s) {
  const int64_t n = means_in.defined() ? means_in.size(0) : 0;
  auto means = checked(means_in, "means", {n, 3});
  auto log_scales = checked(log_scales_in, "log_scales", {n, 3});
  auto quats = checked(quats_in, "quats", {n, 4});
  auto opacity_logits = checked(opacity_logits_in, "opacity_logits", {n, 1});
  auto sh = checked(sh_in, "sh", {n, -1, -1});
  const int64_t K = sh.size(1), C = sh.size(2);
  const int stored_degree = static_cast<int>(std::lround(std::sqrt(static_cast<double>(K)))) - 1;
  if (C < 1 || stored_degree < 0 || stored_degree > 3 || (stored_degree + 1) * (stored_degree + 1) != K)
    lrf::fail("render: sh must be [N, (D+1)^2, C] with D <= 3 and C >= 1, got K = " + std::to_string(K));
  if (s.sh_degree < 0 || s.sh_degree > stored_degree)
    lrf::fail("render: sh_degree " + std::to_string(s.sh_degree) + " exceeds the degree the sh tensor holds (" +
              std::to_string(stored_degree) + ")");
  if (s.width <= 0 || s.height <= 0) lrf::fail("render: the output resolution must be positive");
  if (!(s.fx > 0) || !(s.fy > 0)) lrf::fail("render: focal lengths must be positive");
  if (!(s.near > 0)) lrf::fail("render: the near plane must be positive");
  if (!(s.dilation >= 0)) lrf::fail("render: the dilation must not be negative");
  torch::Tensor background = s.background.defined()
                                 ? checked(s.background.reshape({-1}), "background", {C})
                                 : torch::zeros({C}, torch::kFloat32);

  auto means2d = torch::zeros({n, 2}, torch::kFloat32);
  const bool differentiable = torch::GradMode::is_enabled() &&
                              (means.requires_grad() || log_scales.requires_grad() || quats.requires_grad() ||
                               opacity_logits.requires_grad() || sh.requires_grad());
  if (differentiable) means2d.requires_grad_(true);
  torch::Tensor radii;
  auto out = RenderFunction::apply(means, log_scales, quats, opacity_logits, sh, means2d, s, background, &radii);
  return {out[0], out[1], out[2], means2d, radii};
}

}  // namespace lrf::splat
