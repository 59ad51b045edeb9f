#include "lrf/nerf/nerf_trainer.h"

#include <chrono>
#include <cmath>

#include <ATen/ATen.h>
#include <ATen/CPUGeneratorImpl.h>
#include <ATen/Parallel.h>

#include "lrf/core/error.h"
#include "lrf/core/safetensors.h"
#include "lrf/core/seed_stream.h"
#include "lrf/nerf/ray_sampling.h"

namespace lrf::nerf {
namespace {

constexpr const char* kCheckpointFormat = "lrf latent-nerf checkpoint";
constexpr double kBeta1 = 0.9, kBeta2 = 0.99, kEpsilon = 1e-15;

std::vector<at::Tensor> tensors_of(const NerfField& field) {
  std::vector<at::Tensor> out;
  for (const auto& [name, t] : field.named_tensors()) out.push_back(t);
  return out;
}

// The hash grid is updated lazily (see the header); the MLPs densely.
std::vector<bool> lazy_flags(const NerfField& field) {
  std::vector<bool> out;
  for (const auto& [name, t] : field.named_tensors()) out.push_back(name == "grid.table");
  return out;
}

}  // namespace

void NerfTrainOptions::check() const {
  if (iterations < 1) fail_usage("--steps must be at least 1");
  if (rays_per_step < 1 || rays_per_step > (1 << 20)) fail_usage("--rays must be between 1 and 1048576");
  if (!(lr > 0) || !(lr_final > 0) || !std::isfinite(lr) || !std::isfinite(lr_final))
    fail("NeRF learning rates must be positive");
}

NerfTrainingRays training_rays(const std::vector<Camera>& cameras, const std::vector<at::Tensor>& latents) {
  if (cameras.size() != latents.size() || cameras.empty()) fail("NeRF training: one latent per training camera expected");
  NerfTrainingRays out;
  std::vector<at::Tensor> targets;
  for (size_t k = 0; k < cameras.size(); ++k) {
    const Camera& cam = cameras[k];
    const at::Tensor& z = latents[k];
    if (z.dim() != 3 || z.size(1) != cam.height || z.size(2) != cam.width)
      fail("NeRF training: latent " + std::to_string(k) + " does not match its camera's " + std::to_string(cam.width) +
           "x" + std::to_string(cam.height) + " pixels");
    std::vector<double> o, d;
    camera_rays(cam, &o, &d);
    out.origins.insert(out.origins.end(), o.begin(), o.end());
    out.directions.insert(out.directions.end(), d.begin(), d.end());
    targets.push_back(z.to(at::kFloat).permute({1, 2, 0}).reshape({-1, z.size(0)}));  // row-major pixels, as camera_rays
  }
  out.targets = at::cat(targets, 0).contiguous();
  return out;
}

NerfTrainer::NerfTrainer(NerfField field, NerfTrainingRays rays, const NerfTrainOptions& options)
    : field_(std::move(field)),
      adam_(tensors_of(field_), AdamOptions{options.lr, kBeta1, kBeta2, kEpsilon}, lazy_flags(field_)),
      rays_(std::move(rays)),
      options_(options) {
  options_.check();
  if (rays_.count() == 0) fail("NeRF training: no training rays");
  if (rays_.targets.size(1) != field_.spec.channels)
    fail("NeRF training: the targets have " + std::to_string(rays_.targets.size(1)) + " channels, the field " +
         std::to_string(field_.spec.channels));
}

double NerfTrainer::learning_rate(int64_t step) const {
  const double t = options_.iterations > 1 ? double(step) / double(options_.iterations - 1) : 0.0;
  return options_.lr * std::pow(options_.lr_final / options_.lr, std::min(1.0, t));
}

NerfStepResult NerfTrainer::step() {
  using Clock = std::chrono::steady_clock;
  NerfStepResult r;
  auto generator = at::make_generator<at::CPUGeneratorImpl>(stream_seed(options_.seed, SeedStream::nerf_rays, static_cast<uint64_t>(steps_done())));
  auto t0 = Clock::now();
  const int64_t R = options_.rays_per_step;
  const at::Tensor index = at::randint(rays_.count(), {R}, generator, at::kLong);
  std::vector<double> origins(static_cast<size_t>(3 * R)), directions(static_cast<size_t>(3 * R));
  const int64_t* ip = index.data_ptr<int64_t>();
  for (int64_t k = 0; k < R; ++k)
    for (int a = 0; a < 3; ++a) {
      origins[static_cast<size_t>(3 * k + a)] = rays_.origins[static_cast<size_t>(3 * ip[k] + a)];
      directions[static_cast<size_t>(3 * k + a)] = rays_.directions[static_cast<size_t>(3 * ip[k] + a)];
    }
  const at::Tensor targets = rays_.targets.index_select(0, index);
  const Rays batch{origins.data(), directions.data(), R};
  const at::Tensor s = place_samples(field_, batch, generator);
  r.timings.sampling = std::chrono::duration<double>(Clock::now() - t0).count();

  NerfField grads = field_.zeros_like();
  r.loss = loss_and_gradients(field_, batch, s, targets, &grads, &r.timings);
  if (!std::isfinite(r.loss)) fail("NeRF training diverged at step " + std::to_string(steps_done() + 1) + " (loss not finite)");
  r.psnr = -10.0 * std::log10(std::max(r.loss, 1e-20));
  auto t1 = Clock::now();
  adam_.set_lr(learning_rate(steps_done()));
  adam_.step(tensors_of(grads));
  r.optimizer_seconds = std::chrono::duration<double>(Clock::now() - t1).count();
  r.step = steps_done();
  return r;
}

void NerfTrainer::save_checkpoint(const std::string& path) const {
  adam_.save(path, {{"format", kCheckpointFormat}, {"spec", field_.spec.to_json().dump()}});
}

void NerfTrainer::load_checkpoint(const std::string& path) {
  const auto meta = read_safetensors_metadata(path);
  if (!meta.count("spec")) fail(path, "not a latent-nerf checkpoint (no \"spec\" in its metadata)");
  if (!meta.count("lrf_adam_steps"))
    fail(path, "a latent-NeRF checkpoint of an earlier lrf, whose optimizer state this one does not read: "
               "start the run again without --resume");
  nlohmann::json spec;
  try {
    spec = nlohmann::json::parse(meta.at("spec"));
  } catch (const nlohmann::json::exception& e) {
    fail(path, std::string("the NeRF spec in the metadata is not JSON: ") + e.what());
  }
  if (spec != field_.spec.to_json())
    fail(path, "the checkpoint's field was made with other settings (grid, sizes, samples or scene bounds)");
  int64_t steps = -1;
  try {
    steps = std::stoll(meta.at("lrf_adam_steps"));
  } catch (const std::exception&) {
    fail(path, "bad step count \"" + meta.at("lrf_adam_steps") + "\"");
  }
  if (steps < 0 || steps > options_.iterations)
    fail(path, "holds step " + std::to_string(steps) + ", beyond the run's " + std::to_string(options_.iterations) +
                   " steps (resume with a larger --steps)");
  adam_.load(path);
}

}  // namespace lrf::nerf
