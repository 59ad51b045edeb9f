#include "lrf/finetune/encoder_finetune.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <optional>

#include <torch/torch.h>

#include "lrf/align/correspondence_loss.h"
#include "lrf/autoencoder/kl_vae.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/paths.h"
#include "lrf/core/run_info.h"
#include "lrf/core/seed_stream.h"
#include "lrf/core/training_steps.h"
#include "lrf/finetune/finetune_output.h"
#include "lrf/latent/latent_cache.h"
#include "lrf/optim/param_adam.h"

namespace lrf {
namespace {

// KL(N(mu_a, var_a) || N(mu_b, var_b)) per element.
at::Tensor gaussian_kl(const at::Tensor& mu_a, const at::Tensor& logvar_a, const at::Tensor& mu_b,
                       const at::Tensor& logvar_b) {
  return 0.5 * (logvar_b - logvar_a + (logvar_a.exp() + (mu_a - mu_b).pow(2)) / logvar_b.exp() - 1);
}

}  // namespace

nlohmann::json encoder_finetune_options_json(const EncoderFinetuneOptions& o) {
  nlohmann::json j = {{"scenes", o.scenes},
          {"correspondence_files", o.correspondence_files},
          {"autoencoder", o.autoencoder},
          {"encoder", o.encoder},
          {"max_side", o.max_side},
          {"min_matches", o.min_matches},
          {"pairs", o.batch.pairs},
          {"crop", o.batch.crop},
          {"max_matches", o.batch.max_matches},
          {"min_matches_in_crop", o.batch.min_matches_in_crop},
          {"steps", o.steps},
          {"lambda_corres", o.lambda_corres},
          {"lambda_reg", o.lambda_reg},
          {"kl_weight", o.kl_weight},
          {"base_lr", o.base_lr},
          {"lr", o.lr},
          {"seed", o.seed},
          {"checkpoint_every", o.checkpoint_every}};
  if (!o.scene_resolutions.empty()) {
    j["scene_resolutions"] = nlohmann::json::array();
    for (const auto& r : o.scene_resolutions) j["scene_resolutions"].push_back(r.json());
  }
  return j;
}

namespace {

// What must be equal for a checkpoint to be continued (steps may be extended).
nlohmann::json resume_key(const EncoderFinetuneOptions& o) {
  nlohmann::json j = encoder_finetune_options_json(o);
  j.erase("steps");
  j.erase("checkpoint_every");
  return j;
}

double adam_lr(const EncoderFinetuneOptions& o) { return o.lr > 0 ? o.lr : o.base_lr * 2 * o.batch.pairs; }

}  // namespace

std::string finetune_checkpoint_path(const std::string& out) { return out + ".checkpoint.safetensors"; }

std::string finetune_record_path(const std::string& out) {
  return std::filesystem::path(out).replace_extension(".json").string();
}

Stage1Losses stage1_losses(Autoencoder& model, Autoencoder& original, const PairBatch& batch,
                           const EncoderFinetuneOptions& options) {
  return stage1_losses(model, original, batch, options, batch_share(static_cast<int64_t>(batch.xi.size()), 0, 1));
}

Stage1Losses stage1_losses(Autoencoder& model, Autoencoder& original, const PairBatch& batch,
                           const EncoderFinetuneOptions& options, const BatchShare& share) {
  const bool whole = share.count == share.total;
  const at::Tensor x = whole ? batch.images : batch.images.narrow(0, 2 * share.first, 2 * share.count);
  // Exactly the global batch's value for one process; scaled parts otherwise (see BatchShare).
  const double part = share_weight(share);
  auto scaled = [](const at::Tensor& t, double f) { return f == 1.0 ? t : t * f; };
  Stage1Losses out;
  at::Tensor z, z_for_decoder;
  auto* kl_model = dynamic_cast<KLAutoencoder*>(&model);
  if (kl_model) {
    auto* kl_original = dynamic_cast<KLAutoencoder*>(&original);
    if (!kl_original) fail("Stage I: the original and fine-tuned autoencoders differ in kind");
    at::Tensor moments = kl_model->encode_moments(x);
    const int64_t c = kl_model->latent_channels();
    at::Tensor mu = moments.narrow(1, 0, c), logvar = moments.narrow(1, c, c);
    z = mu;
    // The posterior sample's noise is drawn for the whole batch, so that every rank slices the same draw.
    at::Tensor noise = torch::randn({batch.images.size(0), c, mu.size(2), mu.size(3)}, mu.options());
    if (!whole) noise = noise.narrow(0, 2 * share.first, 2 * share.count);
    z_for_decoder = mu + torch::exp(0.5 * logvar) * noise;
    at::Tensor moments0;
    {
      torch::NoGradGuard no_grad;
      moments0 = kl_original->encode_moments(x);
    }
    out.reg = scaled(gaussian_kl(mu, logvar, moments0.narrow(1, 0, c), moments0.narrow(1, c, c)).mean(), part);
    const double pixels = static_cast<double>(x.size(1) * x.size(2) * x.size(3));
    at::Tensor prior_kl = gaussian_kl(mu, logvar, torch::zeros_like(mu), torch::zeros_like(logvar)).sum() /
                          (static_cast<double>(x.size(0)) * pixels);
    out.vae = scaled((model.decode(z_for_decoder) - x).abs().mean() + options.kl_weight * prior_kl, part);
  } else {
    z = model.encode(x);
    at::Tensor z0;
    {
      torch::NoGradGuard no_grad;
      z0 = original.encode(x);
    }
    out.reg = scaled((z - z0).pow(2).mean(), part);
    out.vae = scaled((model.decode(z) - x).abs().mean(), part);
  }
  // Pairs whose crops kept no match take no part (and no share of the APE weights). The weights are the
  // whole batch's; this rank sums its pairs' terms.
  std::vector<double> apes;
  std::vector<size_t> used;
  for (size_t k = 0; k < batch.xi.size(); ++k) {
    if (batch.xi[k].size(0) > 0) {
      apes.push_back(batch.ape[k]);
      used.push_back(k);
    }
  }
  std::vector<double> w = ape_weights(apes);
  out.corres = torch::zeros({}, z.options());
  for (size_t u = 0; u < used.size(); ++u) {
    const int64_t k = static_cast<int64_t>(used[u]);
    if (k < share.first || k >= share.first + share.count) continue;
    const int64_t a = 2 * (k - share.first);
    out.corres = out.corres + w[u] * correspondence_l1(z[a], z[a + 1], batch.xi[static_cast<size_t>(k)],
                                                       batch.xj[static_cast<size_t>(k)], model.factor());
  }
  out.corres = scaled(out.corres, static_cast<double>(share.world));
  out.total = out.vae + options.lambda_corres * out.corres + options.lambda_reg * out.reg;
  return out;
}

namespace {

// What every rank must agree on before a data-parallel Stage I starts: the options, the model and
// what was read from the scenes.
nlohmann::json stage1_inputs(const EncoderFinetuneOptions& o, const std::vector<PairScene>& scenes, int side) {
  nlohmann::json j = {{"options", encoder_finetune_options_json(o)},
                      {"autoencoder_identity", autoencoder_identity(o.autoencoder, o.encoder)},
                      {"crop_used", side}};
  for (size_t s = 0; s < scenes.size(); ++s) {
    size_t matches = 0;
    for (const auto& p : scenes[s].correspondences.pairs) matches += p.xi.size();
    const auto& cam = scenes[s].scene.views.at(0).camera;
    j["scene_" + std::to_string(s)] = {{"views", scenes[s].scene.views.size()},
                                       {"size", std::to_string(cam.width) + "x" + std::to_string(cam.height)},
                                       {"pairs", scenes[s].correspondences.pairs.size()},
                                       {"matches", matches},
                                       {"correspondences", scenes[s].correspondences.source}};
  }
  return j;
}

}  // namespace

EncoderFinetuneResult finetune_encoder(const EncoderFinetuneOptions& o) {
  namespace fs = std::filesystem;
  if (o.scenes.empty()) fail("finetune-encoder: give at least one scene with --scenes");
  if (!o.encoder.empty()) refuse_output_over_input(o.out, o.encoder, "the starting encoder");
  refuse_output_over_input(o.out, o.autoencoder, "the autoencoder's weights");
  if (!o.correspondence_files.empty() && o.correspondence_files.size() != o.scenes.size()) {
    fail("finetune-encoder: " + std::to_string(o.correspondence_files.size()) + " correspondence files for " +
         std::to_string(o.scenes.size()) + " scenes (give one per scene, in the same order)");
  }
  if (!o.scene_resolutions.empty() && o.scene_resolutions.size() != o.scenes.size()) {
    fail("finetune-encoder: " + std::to_string(o.scene_resolutions.size()) + " scene resolutions for " +
         std::to_string(o.scenes.size()) + " scenes (give one per scene, in the same order)");
  }
  if (o.out.empty()) fail("finetune-encoder: no output file (-o)");
  if (o.steps < 1 || o.batch.pairs < 1) fail("finetune-encoder: --steps and --pairs must be at least 1");
  check_training_steps(o.steps);
  const int world = std::max(1, o.distributed.world_size);
  if (o.batch.pairs < world) {
    fail("finetune-encoder: --pairs " + std::to_string(o.batch.pairs) + " is the global batch, split over " +
         std::to_string(world) + " ranks: give at least one pair per rank");
  }
  const std::string ckpt = finetune_checkpoint_path(o.out);
  auto group = join_data_parallel(o.distributed, "finetune-encoder");

  // Rank 0 alone owns the output; every rank reads the scenes and the model. Whatever stops one rank
  // stops all of them before the first step.
  std::optional<FolderLock> lock;
  std::vector<PairScene> scenes;
  int side = 0;
  std::unique_ptr<Autoencoder> model, original;
  std::string problem;
  try {
    if (group->is_main()) {
      lock.emplace(claim_finetune_output(o.out, ckpt, o.force, o.resume));
      if (!o.resume && fs::exists(ckpt)) fs::remove(ckpt);
    }
    for (size_t s = 0; s < o.scenes.size(); ++s) {
      SceneOptions so;
      so.downscale = 0;  // from max_side, unless the scene has its own
      if (!o.scene_resolutions.empty()) {
        so.images_dir = o.scene_resolutions[s].images;
        so.downscale = o.scene_resolutions[s].downscale;
      }
      scenes.push_back(load_pair_scene(o.scenes[s], so, o.max_side,
                                       o.correspondence_files.empty() ? "" : o.correspondence_files[s], o.min_matches));
    }
    side = effective_crop(scenes, o.batch.crop);
    model = load_autoencoder(o.autoencoder, o.encoder, "");
    original = load_autoencoder(o.autoencoder, o.encoder, "");
  } catch (const Error& e) {
    if (!group->distributed()) throw;
    problem = e.what();
  }
  group->start_together(problem);
  group->require_same_as_main(stage1_inputs(o, scenes, side), "options or inputs");

  original->set_encoder_trainable(false);
  original->set_decoder_trainable(false);
  model->set_decoder_trainable(false);
  model->set_encoder_trainable(true);
  ParamAdam adam(model->encoder_parameters(), {adam_lr(o)});
  const BatchShare share = batch_share(o.batch.pairs, group->rank(), group->world_size());
  if (group->is_main()) {
    log_info("Stage I: " + model->description() + " in " + precision_name(model->precision()) + ", " +
             std::to_string(o.batch.pairs) + " pairs of " + std::to_string(side) + "x" + std::to_string(side) +
             " crops per step" +
             (group->distributed() ? " (split over " + std::to_string(group->world_size()) + " ranks)" : "") +
             ", Adam lr " + std::to_string(adam.lr()));
  }

  FinetuneLoop loop(o);
  loop.task = "finetune-encoder";
  loop.checkpoint = ckpt;
  loop.kind = "finetune-encoder";
  loop.resume_key = resume_key(o).dump();
  loop.resume_hint = "scenes, model, batch, crop, lambdas, learning rate and seed";
  loop.steps = o.steps;
  loop.precision = model->precision();
  loop.adam = &adam;
  loop.group = group.get();
  loop.step_loss = [&](int64_t step) {
    PairBatch batch = sample_pair_batch(scenes, o.batch, o.seed, step);
    torch::manual_seed(stream_seed(o.seed, SeedStream::stage1_posterior, static_cast<uint64_t>(step)));
    Stage1Losses l = stage1_losses(*model, *original, batch, o, share);
    return FinetuneStepLoss{l.total, {{"vae", l.vae.item<double>()},
                                      {"corres", l.corres.item<double>()},
                                      {"reg", l.reg.item<double>()}}};
  };
  FinetuneLoopResult run = run_finetune_loop(loop);

  EncoderFinetuneResult result;
  result.main_rank = group->is_main();
  result.steps = run.steps;
  result.seconds = run.seconds;
  result.total_seconds = run.total_seconds;
  result.sync_seconds = run.sync_seconds;
  result.last_total = run.last_loss;
  result.last_vae = run.last_metrics["vae"];
  result.last_corres = run.last_metrics["corres"];
  result.last_reg = run.last_metrics["reg"];
  if (group->is_main()) {
    model->save_encoder(o.out);
    nlohmann::json record = run_record(encoder_finetune_options_json(o));
    record["autoencoder_identity"] = autoencoder_identity(o.autoencoder, o.encoder);
    record["crop_used"] = side;
    record["adam_lr"] = adam.lr();
    record["precision"] = precision_name(model->precision());
    record["world_size"] = group->world_size();
    record["result"] = {{"steps", result.steps},
                        {"seconds", result.total_seconds},
                        {"seconds_this_session", result.seconds},
                        {"loss", result.last_total},
                        {"vae", result.last_vae},
                        {"corres", result.last_corres},
                        {"reg", result.last_reg}};
    write_json_file(finetune_record_path(o.out), record);
    log_info("wrote " + o.out + " and " + finetune_record_path(o.out));
  }
  finish_together(*group, o.out);
  return result;
}

}  // namespace lrf
