#include "lrf/frames/field_frames.h"

#include <chrono>

#include <torch/torch.h>

#include "lrf/autoencoder/image_tensor.h"
#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/core/threads.h"
#include "lrf/latent/latent_field.h"
#include "lrf/latent/latent_run.h"
#include "lrf/nerf/nerf_render.h"
#include "lrf/nerf/nerf_run.h"
#include "lrf/splat/run/run_folder.h"

namespace lrf {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

void check_size(const Camera& camera, int multiple) {
  if (camera.width < multiple || camera.height < multiple || camera.width % multiple || camera.height % multiple)
    fail("frame size " + std::to_string(camera.width) + "x" + std::to_string(camera.height) +
         " is not a positive multiple of " + std::to_string(multiple));
}

// Depth of a splat field: its Gaussians rendered with a single zero feature, since only the opacity-weighted
// depth and the coverage are read.
cv::Mat splat_depth(const splat::Gaussians& field, const splat::FieldRenderOptions& render, const Camera& camera) {
  apply_thread_count_to_this_thread();
  torch::NoGradGuard no_grad;
  splat::Gaussians shape{field.means, field.log_scales, field.quats, field.opacity_logits,
                         torch::zeros({field.size(), 1, 1}, torch::kFloat32), 0};
  splat::FieldRenderOptions options = render;
  options.sh_degree = 0;
  options.background = torch::zeros({1}, torch::kFloat32);
  const auto out = splat::render_field(shape, camera, options);
  const auto covered = out.alpha[0] > 0.5;
  const auto depth = torch::where(covered, out.depth[0] / out.alpha[0].clamp_min(1e-6), torch::zeros_like(out.depth[0]))
                         .contiguous();
  return cv::Mat(camera.height, camera.width, CV_32F, depth.data_ptr<float>()).clone();
}

class RgbFrames : public FieldFrames {
 public:
  explicit RgbFrames(const std::string& run) : run_(splat::open_field_run(run)) {}
  FieldKind kind() const override { return FieldKind::rgb; }
  bool latent() const override { return false; }
  bool has_depth() const override { return true; }
  const Scene& scene() const override { return run_.scene; }
  int size_multiple() const override { return 1; }
  std::string describe() const override {
    return "RGB field, " + std::to_string(run_.field.size()) + " Gaussians, SH degree " +
           std::to_string(run_.render.sh_degree) + (run_.render.mip ? ", Mip-Splatting" : "");
  }
  cv::Mat render(const Camera& camera, FrameTiming* timing) override {
    check_size(camera, 1);
    apply_thread_count_to_this_thread();
    torch::NoGradGuard no_grad;
    const auto t0 = Clock::now();
    auto image = splat::render_field(run_.field, camera, run_.render).image.clamp(0, 1);
    cv::Mat frame = to_u8(tensor_to_image(image));
    if (timing) *timing = {ms_since(t0), 0.0, 0.0};
    return frame;
  }
  cv::Mat depth(const Camera& camera) override { return splat_depth(run_.field, run_.render, camera); }

 private:
  splat::FieldRun run_;
};

// The frame a latent-space field renders for `camera`: `render_latent` (normalised latents for the latent
// camera) decoded through `ae`, timed in two parts.
template <class RenderLatent>
cv::Mat decoded_frame(const Camera& camera, Autoencoder& ae, const LatentRange& range, RenderLatent render_latent,
                      FrameTiming* timing) {
  check_size(camera, 8);
  apply_thread_count_to_this_thread();
  torch::NoGradGuard no_grad;
  const auto t0 = Clock::now();
  const torch::Tensor zn = render_latent(latent_camera(camera));
  const double render_ms = ms_since(t0);
  const auto t1 = Clock::now();
  cv::Mat frame = to_u8(tensor_to_image(decode_normalised(ae, range, zn)));
  if (timing) *timing = {render_ms, ms_since(t1), 0.0};
  return frame;
}

std::string decoded_by(const std::string& decoder) {
  return decoder.empty() ? "the autoencoder's decoder" : decoder;
}

class LatentFrames : public FieldFrames {
 public:
  LatentFrames(const std::string& run, const std::string& decoder) : run_(open_latent_run(run)) {
    decoder_ = decoder.empty() ? run_.decoder : decoder;
    ae_ = load_autoencoder(run_.autoencoder, run_.encoder, decoder_);
  }
  FieldKind kind() const override { return FieldKind::latent; }
  bool latent() const override { return true; }
  bool has_depth() const override { return true; }
  const Scene& scene() const override { return run_.scene; }
  int size_multiple() const override { return 8; }
  std::string describe() const override {
    return "latent field (" + run_.autoencoder + ", " + std::to_string(run_.range.channels()) + " channels), " +
           std::to_string(run_.field.size()) + " Gaussians, decoded by " +
           decoded_by(decoder_);
  }
  cv::Mat render(const Camera& camera, FrameTiming* timing) override {
    // A feature field's features are lifted to latents.
    return decoded_frame(camera, *ae_, run_.range, [&](const Camera& c) { return render_latent_at(run_, c); }, timing);
  }
  cv::Mat depth(const Camera& camera) override { return splat_depth(run_.field, run_.render, camera); }

 private:
  LatentRun run_;
  std::string decoder_;
  std::unique_ptr<Autoencoder> ae_;
};

// A latent NeRF renders the same normalised latents as a latent field, ray by ray, and is decoded alike
// (through the autoencoder's decoder unless told otherwise: a NeRF is never refined through another).
class NerfFrames : public FieldFrames {
 public:
  NerfFrames(const std::string& run, const std::string& decoder) : run_(nerf::open_nerf_run(run)), decoder_(decoder) {
    ae_ = load_autoencoder(run_.autoencoder, run_.encoder, decoder_);
  }
  FieldKind kind() const override { return FieldKind::latent_nerf; }
  bool latent() const override { return true; }
  bool has_depth() const override { return false; }
  const Scene& scene() const override { return run_.scene; }
  int size_multiple() const override { return 8; }
  std::string describe() const override {
    return "latent NeRF (" + run_.autoencoder + ", " + std::to_string(run_.range.channels()) + " channels), " +
           std::to_string(run_.field.parameter_count()) + " parameters, decoded by " +
           decoded_by(decoder_);
  }
  cv::Mat render(const Camera& camera, FrameTiming* timing) override {
    return decoded_frame(camera, *ae_, run_.range, [&](const Camera& c) { return nerf::render_view(run_.field, c); },
                         timing);
  }
  cv::Mat depth(const Camera&) override {
    fail(run_.out, "a latent NeRF renders no depth map here; the detail pass needs a splat field");
  }

 private:
  nerf::NerfRun run_;
  std::string decoder_;
  std::unique_ptr<Autoencoder> ae_;
};

}  // namespace

std::unique_ptr<FieldFrames> rgb_field_frames(const std::string& run) { return std::make_unique<RgbFrames>(run); }

std::unique_ptr<FieldFrames> latent_field_frames(const std::string& run, const std::string& decoder) {
  return std::make_unique<LatentFrames>(run, decoder);
}

std::unique_ptr<FieldFrames> nerf_field_frames(const std::string& run, const std::string& decoder) {
  return std::make_unique<NerfFrames>(run, decoder);
}

}  // namespace lrf
