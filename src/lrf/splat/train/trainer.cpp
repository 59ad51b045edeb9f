#include "lrf/splat/train/trainer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <random>
#include <sstream>

#include <torch/serialize.h>

#include "lrf/core/atomic_file.h"
#include "lrf/core/seed_stream.h"
#include "lrf/splat/render_field.h"
#include "lrf/splat/train/loss.h"
#include "lrf/splat/train/mip_filter.h"
#include "lrf/splat/train/spatial_order.h"

namespace lrf::splat {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}


// The view seen at 1/factor of its size: each target pixel is the mean of the full-size pixels under it,
// which is what the reduced camera's pixel (its intrinsics scaled by the same ratio) covers.
TrainView reduced_view(const TrainView& v, int factor) {
  const int w = std::max(1, v.camera.width / factor), h = std::max(1, v.camera.height / factor);
  TrainView r{v.name, v.camera.resized(w, h), {}};
  r.target = torch::adaptive_avg_pool2d(v.target.unsqueeze(0), {h, w}).squeeze(0).contiguous();
  return r;
}

}  // namespace

TrainingDiverged::TrainingDiverged(int64_t step, const std::string& what)
    : Error("training diverged at step " + std::to_string(step) + ": " + what), step_(step) {}

Trainer::Trainer(std::vector<TrainView> views, Gaussians init, double extent, TrainerOptions options)
    : views_(std::move(views)), g_(std::move(init)), extent_(extent), options_(std::move(options)) {
  if (views_.empty()) fail("trainer: no training views");
  g_.check("initial Gaussians");
  const int64_t c = g_.channels();
  for (const auto& v : views_) {
    if (options_.objective) break;  // the objective gives the targets their meaning
    if (!v.target.defined() || v.target.dim() != 3 || v.target.size(0) != c ||
        v.target.size(1) != v.camera.height || v.target.size(2) != v.camera.width)
      fail(v.name, "training target must be [" + std::to_string(c) + ", " + std::to_string(v.camera.height) +
                       ", " + std::to_string(v.camera.width) + "] to match the field and camera");
  }
  if (options_.sh_degree > g_.max_sh_degree) fail("trainer: SH degree exceeds the field's");
  if (!options_.background.defined()) options_.background = torch::zeros({c}, torch::kFloat32);
  g_.make_leaves();
  g_.permute_rows(spatial_order(g_.means));  // see spatial_order.h
  adam_ = GaussianAdam(g_, options_.lr, extent_, options_.iterations);
  adam_.sparse = options_.sparse_adam;
  densifier_.resize(g_.size());
  update_filter();
  if (options_.coarse_factor < 1) fail("trainer: the coarse phase's factor must be at least 1");
  if (options_.coarse_factor > 1 && options_.coarse_until > 0) {
    if (options_.objective) fail("trainer: a coarse phase needs photometric targets, not an objective");
    for (const auto& v : views_) coarse_views_.push_back(reduced_view(v, options_.coarse_factor));
  }
}

bool Trainer::coarse_at(int64_t step) const { return !coarse_views_.empty() && step <= options_.coarse_until; }

const TrainView& Trainer::training_view(int view, int64_t step) const {
  return (coarse_at(step) ? coarse_views_ : views_).at(static_cast<size_t>(view));
}

int Trainer::active_sh_degree() const {
  const int64_t every = std::max<int64_t>(options_.schedule.sh_degree_every, 1);
  // Degree goes up at steps every, 2*every, ...; step_ steps are done, the next is step_ + 1.
  return static_cast<int>(std::min<int64_t>(options_.sh_degree, (step_ + 1) / every));
}

int Trainer::view_for_step(int64_t step) const {
  // Each epoch visits every view once in a random order, as Inria's stack of cameras does.
  const int64_t n = static_cast<int64_t>(views_.size());
  const int64_t epoch = step / n, pos = step % n;
  std::vector<int> order(static_cast<size_t>(n));
  std::iota(order.begin(), order.end(), 0);
  std::mt19937_64 rng(stream_seed(options_.seed, SeedStream::view_order, static_cast<uint64_t>(epoch)));
  std::shuffle(order.begin(), order.end(), rng);
  return order[static_cast<size_t>(pos)];
}

RasterSettings Trainer::settings(const Camera& camera) const {
  return field_settings(camera, g_.channels(), {active_sh_degree(), options_.mip, options_.background});
}

void Trainer::update_filter() {
  if (!options_.mip) return;
  std::vector<Camera> cams;
  for (const auto& v : views_) cams.push_back(v.camera);
  filter_ = compute_3d_filter(g_.means, cams);
}

RenderOutput Trainer::render(const Camera& camera, bool grad) { return render_with(camera, grad, nullptr); }

RenderOutput Trainer::render_with(const Camera& camera, bool grad, const ShGradientSink* sink) {
  torch::AutoGradMode mode(grad);
  auto s = settings(camera);
  s.sh_gradient_sink = sink;
  if (options_.mip) {
    auto f = apply_3d_filter(g_.log_scales, g_.opacity_logits, filter_);
    return splat::render(g_.means, f.log_scales, g_.quats, f.opacity_logits, g_.sh, s);
  }
  return splat::render(g_.means, g_.log_scales, g_.quats, g_.opacity_logits, g_.sh, s);
}

StepResult Trainer::step() {
  StepResult r;
  const int64_t step = step_ + 1;  // 1-based, as the schedule is written
  const int view_index = view_for_step(step_);
  const auto& view = training_view(view_index, step);
  const int scale = coarse_at(step) ? options_.coarse_factor : 1;

  auto t0 = Clock::now();
  const Camera camera = options_.camera_of_step ? options_.camera_of_step(view.camera, view_index, step) : view.camera;
  const ShGradientSink* sink = nullptr;
  if (options_.sh_update_in_backward && !options_.sparse_adam) sink = &adam_.sh_row_update(g_, active_sh_degree());
  RenderOutput out = render_with(camera, /*grad=*/true, sink);
  r.timings.render = ms_since(t0);

  t0 = Clock::now();
  torch::Tensor loss, rendered_grad;
  if (options_.objective) {
    ObjectiveValue v = options_.objective(out.image, view_index, step);
    loss = v.loss;
    r.psnr = v.psnr;
    rendered_grad = v.rendered_grad;
    r.timings.loss_backward = v.backward_ms;
  } else {
    loss = photometric_loss(out.image, view.target, options_.lambda_ssim);
    if (options_.psnr_every > 0 && step % options_.psnr_every == 0) r.psnr = psnr(out.image, view.target);
  }
  r.loss = loss.item<double>();
  r.timings.loss = ms_since(t0) - r.timings.loss_backward;
  if (!std::isfinite(r.loss)) throw TrainingDiverged(step, "loss is " + std::to_string(r.loss));

  t0 = Clock::now();
  if (rendered_grad.defined()) {
    out.image.backward(rendered_grad);
  } else {
    loss.backward();
  }
  r.timings.backward = ms_since(t0);
  t0 = Clock::now();
  if (options_.after_backward) options_.after_backward(step);
  r.timings.extra_optimizer = ms_since(t0);

  t0 = Clock::now();
  const auto& sched = options_.schedule;
  if (step < sched.until && out.means2d.grad().defined()) {
    // Radii in full-size pixels, as the screen-size pruning judges them. The positional gradient is in
    // NDC units and meets the same threshold at any resolution; what the reduced views show decides what
    // grows (fern's field grew fewer Gaussians on them, beer-can's more).
    densifier_.accumulate(out.means2d.grad(), scale == 1 ? out.radii : out.radii * scale);
  }
  r.timings.densify = ms_since(t0);

  t0 = Clock::now();
  torch::Tensor touched;
  if (options_.sparse_adam) {
    // Rows the rasterizer reached: every Gaussian that blended into a pixel has an opacity gradient.
    // Visible but fully occluded Gaussians (most of a dense field in a small image) are skipped too.
    auto og = g_.opacity_logits.grad();
    touched = og.defined() ? (og.squeeze(1) != 0) & (out.radii > 0) : out.radii > 0;
  }
  adam_.step(g_, active_sh_degree(), touched);
  for (auto* p : g_.parameters()) p->mutable_grad() = torch::Tensor();
  r.timings.optimizer = ms_since(t0);

  t0 = Clock::now();
  if (sched.densify_at(step)) {
    r.densify = densifier_.densify_and_prune(g_, adam_, extent_, step > sched.opacity_reset_every,
                                             stream_seed(options_.seed, SeedStream::densify_split, static_cast<uint64_t>(step)),
                                             options_.densify);
    sort_spatially(g_, adam_);  // the statistics were just reset: nothing else to reorder
    r.densified = true;
    update_filter();
  }
  if (sched.reset_opacity_at(step)) {
    torch::Tensor coef;
    if (options_.mip) coef = filter_opacity_coef(g_.log_scales, filter_);
    Densifier::reset_opacity(g_, adam_, coef);
  }
  // Mip-Splatting also refreshes the filter every 100 steps once the field stops growing.
  if (options_.mip && step >= sched.until && step % 100 == 0 && step < options_.iterations - 100) update_filter();
  r.timings.densify += ms_since(t0);

  step_ = step;
  r.step = step;
  r.gaussians = g_.size();
  return r;
}

Gaussians Trainer::export_gaussians() const {
  Gaussians out = g_.clone();
  if (options_.mip) {
    torch::NoGradGuard no_grad;
    auto f = apply_3d_filter(g_.log_scales.detach(), g_.opacity_logits.detach(), filter_);
    out.log_scales = f.log_scales;
    out.opacity_logits = f.opacity_logits;
  }
  return out;
}

void Trainer::check_finite() const {
  const auto& names = Gaussians::parameter_names();
  auto params = g_.parameters();
  for (size_t i = 0; i < params.size(); ++i)
    if (!torch::isfinite(params[i]->detach()).all().item<bool>())
      throw TrainingDiverged(step_, "parameter '" + names[i] + "' holds NaN or infinite values");
}

void Trainer::save_checkpoint(const std::string& path) const {
  check_finite();
  torch::serialize::OutputArchive ar;
  const auto& names = Gaussians::parameter_names();
  auto params = g_.parameters();
  for (size_t i = 0; i < params.size(); ++i) ar.write("param." + names[i], params[i]->detach());
  auto state = adam_.state();
  for (size_t i = 0; i < state.size(); ++i) ar.write("adam." + std::to_string(i), state[i]);
  ar.write("densify.grad_accum", densifier_.grad_accum);
  ar.write("densify.denom", densifier_.denom);
  ar.write("densify.max_radii", densifier_.max_radii);
  if (filter_.defined()) ar.write("mip.filter", filter_);
  ar.write("meta", torch::tensor({step_, adam_.steps_taken(), static_cast<int64_t>(g_.max_sh_degree),
                                  static_cast<int64_t>(options_.seed), options_.iterations},
                                 torch::kInt64));
  // Serialised in memory, then written by write_file_atomic, which reports a failed write (a full disk) as
  // an error naming the file and removes its temporary: libtorch's file writer throws from its destructor
  // when the disk fills, which ends the process.
  std::ostringstream bytes;
  ar.save_to(bytes);
  write_file_atomic(path, bytes.str());
}

void Trainer::load_checkpoint(const std::string& path) {
  torch::serialize::InputArchive ar;
  try {
    ar.load_from(path);
  } catch (const c10::Error& e) {
    fail(path, std::string("not a readable lrf checkpoint: ") + e.what_without_backtrace());
  }
  auto read = [&](const std::string& key) {
    torch::Tensor t;
    if (!ar.try_read(key, t)) fail(path, "checkpoint lacks '" + key + "'");
    return t;
  };
  auto meta = read("meta");
  if (meta.numel() != 5) fail(path, "checkpoint metadata has the wrong size");
  auto m = meta.accessor<int64_t, 1>();
  if (static_cast<uint64_t>(m[3]) != options_.seed)
    fail(path, "checkpoint was made with seed " + std::to_string(m[3]) + ", this run uses " +
                   std::to_string(options_.seed));
  Gaussians g;
  g.max_sh_degree = static_cast<int>(m[2]);
  const auto& names = Gaussians::parameter_names();
  auto params = g.parameters();
  for (size_t i = 0; i < params.size(); ++i) *params[i] = read("param." + names[i]);
  g.check(path);
  if (g.max_sh_degree < options_.sh_degree)
    fail(path, "checkpoint holds SH degree " + std::to_string(g.max_sh_degree) + ", this run trains degree " +
                   std::to_string(options_.sh_degree));
  if (g.channels() != g_.channels()) fail(path, "checkpoint has " + std::to_string(g.channels()) +
                                                    " channels, the scene's targets have " +
                                                    std::to_string(g_.channels()));
  std::vector<torch::Tensor> state;
  for (int i = 0; i < 2 * GaussianAdam::kGroups; ++i) {
    state.push_back(read("adam." + std::to_string(i)));
    if (state.back().sizes() != params[i % GaussianAdam::kGroups]->sizes())
      fail(path, "checkpoint optimizer state does not match its parameters");
  }
  g.make_leaves();
  g_ = std::move(g);
  adam_.set_state(state, m[1]);
  densifier_.grad_accum = read("densify.grad_accum");
  densifier_.denom = read("densify.denom");
  densifier_.max_radii = read("densify.max_radii");
  if (densifier_.grad_accum.numel() != g_.size()) fail(path, "checkpoint densification statistics do not match");
  if (options_.mip) {
    if (!ar.try_read("mip.filter", filter_)) update_filter();
  }
  step_ = m[0];
}

}  // namespace lrf::splat
