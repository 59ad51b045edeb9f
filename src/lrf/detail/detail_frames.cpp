#include "lrf/detail/detail_frames.h"

#include <chrono>

#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/detail/depth_sweep.h"
#include "lrf/detail/source_views.h"
#include "lrf/detail/view_warp.h"

namespace lrf::detail {

DetailFrames::DetailFrames(std::unique_ptr<FieldFrames> frames, const DetailOptions& options)
    : frames_(std::move(frames)), options_(options) {
  if (frames_->kind() == FieldKind::latent_nerf)
    fail("the detail pass needs a splat field's depth; a latent NeRF has none here");
  if (frames_->scene().train_indices.empty()) fail(frames_->scene().root, "the scene has no training views to borrow from");
  if (options_.views < 1) fail_usage("--detail-views must be at least 1");
  sources_.resize(frames_->scene().views.size());
}

std::string DetailFrames::describe() const {
  return frames_->describe() + ", with detail from its " + std::to_string(options_.views) +
         " nearest training photographs";
}

const DetailFrames::Source& DetailFrames::source(int view) {
  auto& slot = sources_.at(view);
  if (!slot) {
    const auto t0 = std::chrono::steady_clock::now();
    const Camera& camera = scene().views[view].camera;
    slot = std::make_unique<Source>(Source{scene().load_image(view), frames_->depth(camera)});
    source_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  return *slot;
}

cv::Mat DetailFrames::render(const Camera& camera, FrameTiming* timing) {
  const cv::Mat decoded = to_float(frames_->render(camera, timing));
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<int> views = nearest_training_views(scene(), camera, options_.views);
  std::vector<SweepSource> sources;
  for (int view : views) {
    const Source& s = source(view);
    sources.push_back({&s.image, &s.depth, &scene().views[view].camera});
    borrowed_.insert(view);
  }
  DepthSweepOptions sweep;
  sweep.range = options_.sweep_range;
  sweep.steps = options_.sweep_steps;
  sweep.window = options_.sweep_window;
  sweep.occlusion_tolerance = options_.occlusion_tolerance;
  const cv::Mat depth = sweep_depth(frames_->depth(camera), camera, sources, sweep);
  std::vector<WarpedView> warped;
  for (const auto& s : sources)
    warped.push_back(warp_view(*s.image, *s.depth, *s.camera, depth, camera, options_.occlusion_tolerance));
  cv::Mat frame = to_u8(blend_detail(decoded, warped, options_));
  if (timing) timing->detail_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return frame;
}

}  // namespace lrf::detail
