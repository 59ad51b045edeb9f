#include "lrf/finetune/encoder_finetune.h"

#include <chrono>
#include <cmath>
#include <filesystem>

#include <torch/torch.h>

#include "lrf/align/correspondence_loss.h"
#include "lrf/autoencoder/kl_vae.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/progress.h"
#include "lrf/core/run_info.h"
#include "lrf/latent/latent_cache.h"
#include "lrf/finetune/adam_checkpoint.h"
#include "lrf/finetune/finetune_output.h"

namespace lrf {
namespace {

// KL(N(mu_a, var_a) || N(mu_b, var_b)) per element.
at::Tensor gaussian_kl(const at::Tensor& mu_a, const at::Tensor& logvar_a, const at::Tensor& mu_b,
                       const at::Tensor& logvar_b) {
  return 0.5 * (logvar_b - logvar_a + (logvar_a.exp() + (mu_a - mu_b).pow(2)) / logvar_b.exp() - 1);
}

}  // namespace

nlohmann::json encoder_finetune_options_json(const EncoderFinetuneOptions& o) {
  return {{"scenes", o.scenes},
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
  const at::Tensor& x = batch.images;
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
    z_for_decoder = mu + torch::exp(0.5 * logvar) * torch::randn_like(mu);
    at::Tensor moments0;
    {
      torch::NoGradGuard no_grad;
      moments0 = kl_original->encode_moments(x);
    }
    out.reg = gaussian_kl(mu, logvar, moments0.narrow(1, 0, c), moments0.narrow(1, c, c)).mean();
    const double pixels = static_cast<double>(x.size(1) * x.size(2) * x.size(3));
    at::Tensor prior_kl = gaussian_kl(mu, logvar, torch::zeros_like(mu), torch::zeros_like(logvar)).sum() /
                          (static_cast<double>(x.size(0)) * pixels);
    out.vae = (model.decode(z_for_decoder) - x).abs().mean() + options.kl_weight * prior_kl;
  } else {
    z = model.encode(x);
    at::Tensor z0;
    {
      torch::NoGradGuard no_grad;
      z0 = original.encode(x);
    }
    out.reg = (z - z0).pow(2).mean();
    out.vae = (model.decode(z) - x).abs().mean();
  }
  // Pairs whose crops kept no match take no part (and no share of the APE weights).
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
    const size_t k = used[u];
    const int64_t a = static_cast<int64_t>(2 * k);
    out.corres = out.corres + w[u] * correspondence_l1(z[a], z[a + 1], batch.xi[k], batch.xj[k], model.factor());
  }
  out.total = out.vae + options.lambda_corres * out.corres + options.lambda_reg * out.reg;
  return out;
}

EncoderFinetuneResult finetune_encoder(const EncoderFinetuneOptions& o) {
  namespace fs = std::filesystem;
  if (o.scenes.empty()) fail("finetune-encoder: give at least one scene with --scenes");
  if (!o.correspondence_files.empty() && o.correspondence_files.size() != o.scenes.size()) {
    fail("finetune-encoder: " + std::to_string(o.correspondence_files.size()) + " correspondence files for " +
         std::to_string(o.scenes.size()) + " scenes (give one per scene, in the same order)");
  }
  if (o.out.empty()) fail("finetune-encoder: no output file (-o)");
  if (o.steps < 1 || o.batch.pairs < 1) fail("finetune-encoder: --steps and --pairs must be at least 1");
  const std::string ckpt = finetune_checkpoint_path(o.out);
  const auto lock = claim_finetune_output(o.out, ckpt, o.force, o.resume);
  if (!o.resume && fs::exists(ckpt)) fs::remove(ckpt);

  std::vector<PairScene> scenes;
  for (size_t s = 0; s < o.scenes.size(); ++s) {
    SceneOptions so;
    so.downscale = 0;
    scenes.push_back(load_pair_scene(o.scenes[s], so, o.max_side,
                                     o.correspondence_files.empty() ? "" : o.correspondence_files[s], o.min_matches));
  }
  const int side = effective_crop(scenes, o.batch.crop);

  auto model = load_autoencoder(o.autoencoder, o.encoder, "");
  auto original = load_autoencoder(o.autoencoder, o.encoder, "");
  original->set_encoder_trainable(false);
  original->set_decoder_trainable(false);
  model->set_decoder_trainable(false);
  model->set_encoder_trainable(true);
  ParamAdam adam(model->encoder_parameters(), {adam_lr(o)});
  const std::string key = resume_key(o).dump();
  int64_t start = 0;
  if (o.resume) {
    auto meta = adam.load(ckpt);
    if (meta["lrf_resume_key"] != key) {
      fail(ckpt, "was written with different options; resume with the same scenes, model, batch, crop, lambdas, "
                 "learning rate and seed (checkpoint: " + meta["lrf_resume_key"] + ")");
    }
    warn_if_precision_changed(meta, model->precision(), ckpt);
    start = adam.steps();
    log_info("resuming from " + ckpt + " at step " + std::to_string(start));
  }
  log_info("Stage I: " + model->description() + " in " + precision_name(model->precision()) + ", " +
           std::to_string(o.batch.pairs) + " pairs of " +
           std::to_string(side) + "x" + std::to_string(side) + " crops per step, Adam lr " + std::to_string(adam.lr()));

  auto save_checkpoint = [&] {
    adam.save(ckpt, {{"lrf_kind", "finetune-encoder"}, {"lrf_resume_key", key}, precision_metadata(model->precision())});
  };
  EncoderFinetuneResult result;
  Progress progress("finetune-encoder", o.steps, 2.0, start);
  const auto t0 = std::chrono::steady_clock::now();
  for (int64_t step = start; step < o.steps; ++step) {
    PairBatch batch = sample_pair_batch(scenes, o.batch, o.seed, step);
    torch::manual_seed(o.seed * 1000003ull + static_cast<uint64_t>(step));  // the KL-VAE's posterior sample
    adam.zero_grad();
    Stage1Losses l = stage1_losses(*model, *original, batch, o);
    const double total = l.total.item<double>();
    if (!std::isfinite(total)) fail_non_finite_loss(o.out, total, step + 1, ckpt);
    l.total.backward();
    adam.step();
    result.last_total = total;
    result.last_vae = l.vae.item<double>();
    result.last_corres = l.corres.item<double>();
    result.last_reg = l.reg.item<double>();
    progress.update(step + 1, {{"loss", total}, {"vae", result.last_vae}, {"corres", result.last_corres},
                               {"reg", result.last_reg}});
    if (o.checkpoint_every > 0 && (step + 1) % o.checkpoint_every == 0 && step + 1 < o.steps) save_checkpoint();
  }
  progress.finish();
  save_checkpoint();
  result.steps = o.steps;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  model->save_encoder(o.out);
  nlohmann::json record = run_record(encoder_finetune_options_json(o));
  record["autoencoder_identity"] = autoencoder_identity(o.autoencoder, o.encoder);
  record["crop_used"] = side;
  record["adam_lr"] = adam.lr();
  record["precision"] = precision_name(model->precision());
  record["result"] = {{"steps", result.steps},
                      {"seconds_this_session", result.seconds},
                      {"loss", result.last_total},
                      {"vae", result.last_vae},
                      {"corres", result.last_corres},
                      {"reg", result.last_reg}};
  write_json_file(finetune_record_path(o.out), record);
  log_info("wrote " + o.out + " and " + finetune_record_path(o.out));
  return result;
}

}  // namespace lrf
