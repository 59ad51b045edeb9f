#include "lrf/detail/detail_frames.h"

#include <chrono>
#include <cmath>
#include <cstdio>

#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/core/log.h"
#include "lrf/detail/depth_sweep.h"
#include "lrf/detail/source_views.h"
#include "lrf/detail/view_warp.h"

namespace lrf::detail {

DetailFrames::DetailFrames(std::unique_ptr<FieldFrames> frames, const DetailOptions& options)
    : frames_(std::move(frames)), options_(options) {
  if (!frames_->has_depth())
    fail("the detail pass needs a splat field's depth; a latent NeRF has none here");
  if (frames_->scene().train_indices.empty()) fail(frames_->scene().root, "the scene has no training views to borrow from");
  if (options_.views < 1) fail_usage("--detail-views must be at least 1");
  if (options_.calibration_views < 0) fail_usage("--detail-calibration-views must be 0 or more");
  sources_.resize(frames_->scene().views.size());
  if (options_.calibration_views > 0 || options_.learned_blend) calibrate();
}

// Evenly spread training views, each standing in for a novel view (borrowing from the others only).
void DetailFrames::calibrate() {
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<int>& train = scene().train_indices;
  // A view needs at least one other to borrow from.
  const int wanted = options_.learned_blend ? std::max(options_.learning_views, options_.calibration_views)
                                            : options_.calibration_views;
  const int count = std::min<int>(wanted, static_cast<int>(train.size()) - 1);
  if (count < 1) return;
  std::vector<CalibrationSample> samples;
  for (int k = 0; k < count; ++k) {
    const int view = train[(2 * k + 1) * train.size() / (2 * count)];
    Inputs in = inputs(scene().views[view].camera, view, nullptr);
    samples.push_back({source(view).image, std::move(in.decoded), std::move(in.warped)});
    calibration_views_.push_back(view);
  }
  if (options_.calibration_views > 0) {
    calibration_ = calibrate_decoded_weight(samples, options_);
    options_.decoded_weight = calibration_.decoded_weight;
    log_calibration(count);
  }
  if (options_.learned_blend) {
    BlendNetworkOptions network;
    network.steps = options_.learning_steps;
    network_ = BlendNetwork::learn(samples, options_, network, &network_report_);
    char line[200];
    std::snprintf(line, sizeof line,
                  "detail pass: a blend learned on %d training views scores %.2f dB on %d others, the hand-made one "
                  "%.2f dB (%.0f s): %s",
                  network_report_.learned_on, network_report_.learned_psnr, network_report_.held_out,
                  network_report_.handmade_psnr, network_report_.seconds,
                  network_report_.used ? "the learned one is used" : "the hand-made one is kept");
    log_info(line);
  }
  borrowed_.clear();  // what frames borrow, not the calibration
  calibration_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void DetailFrames::log_calibration(int count) const {
  double alone = 0, best = 0;
  for (const auto& c : calibration_.scores) {
    if (!std::isfinite(c.decoded_weight)) alone = c.psnr;
    if (c.decoded_weight == calibration_.decoded_weight) best = c.psnr;
  }
  char line[200];
  if (std::isfinite(calibration_.decoded_weight))
    std::snprintf(line, sizeof line, "the frames alone score %.2f dB, blended %.2f dB (decoded weight %g)",
                  alone, best, calibration_.decoded_weight);
  else
    std::snprintf(line, sizeof line, "the frames alone score %.2f dB, better than any blend: the pass is left out", alone);
  log_info("detail pass, on " + std::to_string(count) + " training views each borrowing from the others: " + line);
}

std::string DetailFrames::describe() const {
  if (network_)
    return frames_->describe() + ", with detail from its " + std::to_string(options_.views) +
           " nearest training photographs (a blend learned on its training views)";
  if (!std::isfinite(options_.decoded_weight))
    return frames_->describe() + ", as decoded (on its training views the photographs did not help)";
  char weight[32];
  std::snprintf(weight, sizeof weight, "%g", options_.decoded_weight);
  return frames_->describe() + ", with detail from its " + std::to_string(options_.views) +
         " nearest training photographs (decoded weight " + weight + ")";
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

DetailFrames::Inputs DetailFrames::inputs(const Camera& camera, int except, FrameTiming* timing) {
  Inputs in;
  in.decoded = to_float(frames_->render(camera, timing));
  const std::vector<int> views = nearest_training_views(scene(), camera, options_.views, except);
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
  for (const auto& s : sources)
    in.warped.push_back(warp_view(*s.image, *s.depth, *s.camera, depth, camera, options_.occlusion_tolerance));
  return in;
}

cv::Mat DetailFrames::render(const Camera& camera, FrameTiming* timing) {
  if (!network_ && !std::isfinite(options_.decoded_weight)) return frames_->render(camera, timing);
  const auto t0 = std::chrono::steady_clock::now();
  Inputs in = inputs(camera, -1, timing);
  cv::Mat frame = to_u8(network_ ? network_->blend(in.decoded, in.warped) : blend_detail(in.decoded, in.warped, options_));
  if (timing) {
    // inputs() includes the field's own render and decode, which timing holds already.
    const double total_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    timing->detail_ms = total_ms - timing->render_ms - timing->decode_ms;
  }
  return frame;
}

}  // namespace lrf::detail
