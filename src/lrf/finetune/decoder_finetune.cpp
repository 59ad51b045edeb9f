#include "lrf/finetune/decoder_finetune.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <random>

#include <torch/torch.h>

#include "lrf/autoencoder/autoencoder.h"
#include "lrf/autoencoder/image_tensor.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/progress.h"
#include "lrf/core/run_info.h"
#include "lrf/latent/latent_cache.h"
#include "lrf/latent/latent_run.h"
#include "lrf/finetune/adam_checkpoint.h"
#include "lrf/finetune/finetune_output.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {

struct Sample {
  at::Tensor latent;  // raw [C, h, w]
  at::Tensor image;   // [3, 8h, 8w] in [0, 1]
};

// Renders every training and held-out view of each field once (no gradient): the Stage III dataset.
void build_dataset(const DecoderFinetuneOptions& o, std::vector<Sample>* train, std::vector<Sample>* novel,
                   nlohmann::json* scenes) {
  const std::string identity = autoencoder_identity(o.autoencoder, o.encoder);
  torch::NoGradGuard no_grad;
  for (const auto& dir : o.fields) {
    if (!is_latent_run(dir)) fail(dir, "not a latent field (make one with `lrf train --space latent`)");
    LatentRun run = open_latent_run(dir);
    const std::string field_identity = autoencoder_identity(run.autoencoder, run.encoder);
    if (field_identity != identity) {
      fail(dir, "was trained with the autoencoder " + field_identity + " but the decoder is fine-tuned for " + identity +
                    " (pass the same --autoencoder and --encoder)");
    }
    scenes->push_back(run.config.value("scene", std::string()));
    for (const auto* split : {&run.scene.train_indices, &run.scene.test_indices}) {
      for (int i : *split) {
        Sample s;
        s.latent = run.range.denormalize(render_latent(run, i)).contiguous();
        s.image = image_to_batch(run.scene.load_image(i))[0];
        if (s.image.size(1) != 8 * s.latent.size(1) || s.image.size(2) != 8 * s.latent.size(2)) {
          fail(dir, "view " + run.scene.views[static_cast<size_t>(i)].name + ": image and latent sizes disagree");
        }
        (split == &run.scene.train_indices ? train : novel)->push_back(std::move(s));
      }
    }
  }
}

// `count` aligned random crops from `samples`: latents [count, C, c/8, c/8] and images [count, 3, c, c].
std::pair<at::Tensor, at::Tensor> sample_crops(const std::vector<Sample>& samples, int count, int crop,
                                               std::mt19937_64& rng) {
  std::vector<at::Tensor> z, x;
  const int64_t lc = crop / 8;
  for (int k = 0; k < count; ++k) {
    const Sample& s = samples[std::uniform_int_distribution<size_t>(0, samples.size() - 1)(rng)];
    const int64_t ly = std::uniform_int_distribution<int64_t>(0, s.latent.size(1) - lc)(rng);
    const int64_t lx = std::uniform_int_distribution<int64_t>(0, s.latent.size(2) - lc)(rng);
    z.push_back(s.latent.narrow(1, ly, lc).narrow(2, lx, lc));
    x.push_back(s.image.narrow(1, 8 * ly, crop).narrow(2, 8 * lx, crop));
  }
  return {at::stack(z), at::stack(x)};
}

nlohmann::json resume_key(const DecoderFinetuneOptions& o) {
  nlohmann::json j = decoder_finetune_options_json(o);
  j.erase("steps");
  j.erase("checkpoint_every");
  return j;
}

}  // namespace

nlohmann::json decoder_finetune_options_json(const DecoderFinetuneOptions& o) {
  return {{"fields", o.fields},       {"autoencoder", o.autoencoder}, {"encoder", o.encoder},
          {"decoder", o.decoder},     {"steps", o.steps},             {"batch", o.batch},
          {"crop", o.crop},           {"weight_train", o.weight_train}, {"weight_novel", o.weight_novel},
          {"base_lr", o.base_lr},     {"lr", o.lr},                   {"seed", o.seed},
          {"checkpoint_every", o.checkpoint_every}};
}

std::string decoder_checkpoint_path(const std::string& out) { return out + ".checkpoint.safetensors"; }
std::string decoder_record_path(const std::string& out) { return fs::path(out).replace_extension(".json").string(); }

DecoderFinetuneResult finetune_decoder(const DecoderFinetuneOptions& o) {
  if (o.fields.empty()) fail("finetune-decoder: give at least one latent field with --fields");
  if (o.out.empty()) fail("finetune-decoder: no output file (-o)");
  if (o.steps < 1 || o.batch < 1) fail("finetune-decoder: --steps and --batch must be at least 1");
  if (o.weight_train < 0 || o.weight_novel < 0 || o.weight_train + o.weight_novel <= 0)
    fail("finetune-decoder: the loss weights must be >= 0 and not both 0");
  const std::string ckpt = decoder_checkpoint_path(o.out);
  const auto lock = claim_finetune_output(o.out, ckpt, o.force, o.resume);

  std::vector<Sample> train, novel;
  nlohmann::json scenes = nlohmann::json::array();
  build_dataset(o, &train, &novel, &scenes);
  if (train.empty() && o.weight_train > 0) fail(o.fields.front(), "the fields have no training views");
  if (novel.empty() && o.weight_novel > 0) {
    fail(o.fields.front(), "the fields have no held-out views for the novel-view term (train them with test views, "
                           "or pass --weight-novel 0)");
  }
  int crop = o.crop / 8 * 8;
  for (const auto* set : {&train, &novel}) {
    for (const auto& s : *set) crop = static_cast<int>(std::min<int64_t>({crop, s.image.size(1), s.image.size(2)}));
  }
  if (crop < 8) fail("finetune-decoder: --crop must be at least 8");
  if (!o.resume && fs::exists(ckpt)) fs::remove(ckpt);

  auto ae = load_autoencoder(o.autoencoder, o.encoder, o.decoder);
  ae->set_encoder_trainable(false);
  ae->set_decoder_trainable(true);
  const int per_step = (o.weight_train > 0 ? o.batch : 0) + (o.weight_novel > 0 ? o.batch : 0);
  ParamAdam adam(ae->decoder_parameters(), {o.lr > 0 ? o.lr : o.base_lr * per_step});
  const std::string key = resume_key(o).dump();
  if (o.resume) {
    auto meta = adam.load(ckpt);
    if (meta["lrf_resume_key"] != key) {
      fail(ckpt, "was written with different options; resume with the same fields, model, batch, crop, weights, "
                 "learning rate and seed");
    }
    warn_if_precision_changed(meta, ae->precision(), ckpt);
    log_info("resuming from " + ckpt + " at step " + std::to_string(adam.steps()));
  }
  log_info("Stage III: " + ae->description() + ", " + std::to_string(train.size()) + " training and " +
           std::to_string(novel.size()) + " held-out rendered views, " + std::to_string(o.batch) + "+" +
           std::to_string(o.batch) + " crops of " + std::to_string(crop) + " px per step, Adam lr " +
           std::to_string(adam.lr()));
  auto save_checkpoint = [&] {
    adam.save(ckpt, {{"lrf_kind", "finetune-decoder"}, {"lrf_resume_key", key}, precision_metadata(ae->precision())});
  };

  DecoderFinetuneResult r;
  r.train_samples = static_cast<int64_t>(train.size());
  r.novel_samples = static_cast<int64_t>(novel.size());
  Progress progress("finetune-decoder", o.steps, 2.0, adam.steps());
  const auto t0 = std::chrono::steady_clock::now();
  for (int64_t step = adam.steps(); step < o.steps; ++step) {
    std::mt19937_64 rng(o.seed * 0x9E3779B97F4A7C15ull + static_cast<uint64_t>(step) * 0xD1B54A32D192ED03ull + 7);
    adam.zero_grad();
    at::Tensor loss = torch::zeros({});
    double l_train = 0, l_novel = 0;
    if (o.weight_train > 0) {
      auto [z, x] = sample_crops(train, o.batch, crop, rng);
      at::Tensor l = (ae->decode_unclamped(z) - x).abs().mean();
      l_train = l.item<double>();
      loss = loss + o.weight_train * l;
    }
    if (o.weight_novel > 0) {
      auto [z, x] = sample_crops(novel, o.batch, crop, rng);
      at::Tensor l = (ae->decode_unclamped(z) - x).abs().mean();
      l_novel = l.item<double>();
      loss = loss + o.weight_novel * l;
    }
    const double total = loss.item<double>();
    if (!std::isfinite(total)) fail_non_finite_loss(o.out, total, step + 1, ckpt);
    loss.backward();
    adam.step();
    r.last_loss = total;
    r.last_train = l_train;
    r.last_novel = l_novel;
    progress.update(step + 1, {{"loss", total}, {"l1_train", l_train}, {"l1_novel", l_novel}});
    if (o.checkpoint_every > 0 && (step + 1) % o.checkpoint_every == 0 && step + 1 < o.steps) save_checkpoint();
  }
  progress.finish();
  save_checkpoint();
  r.steps = o.steps;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ae->save_decoder(o.out);
  nlohmann::json record = run_record(decoder_finetune_options_json(o));
  record["field_scenes"] = scenes;
  record["autoencoder_identity"] = autoencoder_identity(o.autoencoder, o.encoder);
  record["crop_used"] = crop;
  record["adam_lr"] = adam.lr();
  record["precision"] = precision_name(ae->precision());
  record["result"] = {{"steps", r.steps},
                      {"train_samples", r.train_samples},
                      {"novel_samples", r.novel_samples},
                      {"seconds_this_session", r.seconds},
                      {"loss", r.last_loss},
                      {"l1_train", r.last_train},
                      {"l1_novel", r.last_novel}};
  write_json_file(decoder_record_path(o.out), record);
  log_info("wrote " + o.out + " and " + decoder_record_path(o.out));
  return r;
}

}  // namespace lrf
