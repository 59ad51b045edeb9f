#include "lrf/finetune/decoder_finetune.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <optional>
#include <random>

#include <torch/torch.h>

#include "lrf/autoencoder/autoencoder.h"
#include "lrf/autoencoder/image_tensor.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/paths.h"
#include "lrf/core/run_info.h"
#include "lrf/core/seed_stream.h"
#include "lrf/core/training_steps.h"
#include "lrf/finetune/finetune_loop.h"
#include "lrf/finetune/finetune_output.h"
#include "lrf/finetune/stage3_terms.h"
#include "lrf/latent/latent_cache.h"
#include "lrf/latent/latent_run.h"
#include "lrf/optim/param_adam.h"

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
    // open_latent_run refuses a folder that is no run, or a run of another kind, as every command that
    // opens a latent run does.
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
  nlohmann::json j = {{"fields", o.fields},       {"autoencoder", o.autoencoder}, {"encoder", o.encoder},
          {"decoder", o.decoder},     {"steps", o.steps},             {"batch", o.batch},
          {"crop", o.crop},           {"weight_train", o.weight_train}, {"weight_novel", o.weight_novel},
          {"base_lr", o.base_lr},     {"lr", o.lr},                   {"seed", o.seed},
          {"checkpoint_every", o.checkpoint_every}};
  // Recorded only when used, so that records of the paper's loss made before the option still match.
  if (o.lambda_ssim != 0) j["lambda_ssim"] = o.lambda_ssim;
  if (o.weight_roundtrip != 0) j["weight_roundtrip"] = o.weight_roundtrip;
  return j;
}

std::string decoder_checkpoint_path(const std::string& out) { return out + ".checkpoint.safetensors"; }
std::string decoder_record_path(const std::string& out) { return fs::path(out).replace_extension(".json").string(); }

namespace {

// What every rank must agree on before a data-parallel Stage III starts: the options, the model and the
// rendered dataset (its sizes and a checksum of its latents).
nlohmann::json stage3_inputs(const DecoderFinetuneOptions& o, const std::vector<Sample>& train,
                             const std::vector<Sample>& novel, int crop) {
  double checksum = 0;
  for (const auto* set : {&train, &novel}) {
    for (const auto& s : *set) checksum += s.latent.to(at::kDouble).sum().item<double>();
  }
  return {{"options", decoder_finetune_options_json(o)},
          {"autoencoder_identity", autoencoder_identity(o.autoencoder, o.encoder)},
          {"train_views", train.size()},
          {"novel_views", novel.size()},
          {"crop_used", crop},
          // Rendering is deterministic on one kind of CPU; a few digits are enough to tell other data.
          {"latent_checksum", std::to_string(static_cast<float>(checksum))}};
}

}  // namespace

DecoderFinetuneResult finetune_decoder(const DecoderFinetuneOptions& o) {
  if (o.fields.empty()) fail("finetune-decoder: give at least one latent field with --fields");
  if (o.out.empty()) fail("finetune-decoder: no output file (-o)");
  if (!o.decoder.empty()) refuse_output_over_input(o.out, o.decoder, "the starting decoder");
  if (!o.encoder.empty()) refuse_output_over_input(o.out, o.encoder, "the fields' encoder");
  refuse_output_over_input(o.out, o.autoencoder, "the autoencoder's weights");
  if (o.steps < 1 || o.batch < 1) fail("finetune-decoder: --steps and --batch must be at least 1");
  check_training_steps(o.steps);
  if (o.weight_train < 0 || o.weight_novel < 0 || o.weight_train + o.weight_novel <= 0)
    fail("finetune-decoder: the loss weights must be >= 0 and not both 0");
  if (!(o.lambda_ssim >= 0 && o.lambda_ssim <= 1)) fail_usage("finetune-decoder: --lambda-ssim must be between 0 and 1");
  if (!(o.weight_roundtrip >= 0 && std::isfinite(o.weight_roundtrip)))
    fail_usage("finetune-decoder: --weight-roundtrip must be a finite number >= 0");
  const int world = std::max(1, o.distributed.world_size);
  if (o.batch < world) {
    fail("finetune-decoder: --batch " + std::to_string(o.batch) + " is the global batch, split over " +
         std::to_string(world) + " ranks: give at least one crop per rank");
  }
  const std::string ckpt = decoder_checkpoint_path(o.out);
  auto group = join_data_parallel(o.distributed, "finetune-decoder");

  // Rank 0 alone owns the output; every rank renders the dataset and loads the model. Whatever stops one
  // rank stops all of them before the first step.
  std::optional<FolderLock> lock;
  std::vector<Sample> train, novel;
  nlohmann::json scenes = nlohmann::json::array();
  int crop = o.crop / 8 * 8;
  std::unique_ptr<Autoencoder> ae;
  std::string problem;
  try {
    if (group->is_main()) lock.emplace(claim_finetune_output(o.out, ckpt, o.force, o.resume));
    build_dataset(o, &train, &novel, &scenes);
    if (train.empty() && (o.weight_train > 0 || o.weight_roundtrip > 0)) fail(o.fields.front(), "the fields have no training views");
    if (novel.empty() && o.weight_novel > 0) {
      fail(o.fields.front(), "the fields have no held-out views for the novel-view term (train them with test views, "
                             "or pass --weight-novel 0)");
    }
    for (const auto* set : {&train, &novel}) {
      for (const auto& s : *set) crop = static_cast<int>(std::min<int64_t>({crop, s.image.size(1), s.image.size(2)}));
    }
    if (crop < 8) fail("finetune-decoder: --crop must be at least 8");
    if (group->is_main() && !o.resume && fs::exists(ckpt)) fs::remove(ckpt);
    ae = load_autoencoder(o.autoencoder, o.encoder, o.decoder);
  } catch (const Error& e) {
    if (!group->distributed()) throw;
    problem = e.what();
  }
  group->start_together(problem);
  group->require_same_as_main(stage3_inputs(o, train, novel, crop), "options or inputs");

  ae->set_encoder_trainable(false);
  ae->set_decoder_trainable(true);
  const int per_step = (o.weight_train > 0 ? o.batch : 0) + (o.weight_novel > 0 ? o.batch : 0);
  ParamAdam adam(ae->decoder_parameters(), {o.lr > 0 ? o.lr : o.base_lr * per_step});
  const BatchShare share = batch_share(o.batch, group->rank(), group->world_size());
  if (group->is_main()) {
    log_info("Stage III: " + ae->description() + ", " + std::to_string(train.size()) + " training and " +
             std::to_string(novel.size()) + " held-out rendered views, " + std::to_string(o.batch) + "+" +
             std::to_string(o.batch) + " crops of " + std::to_string(crop) + " px per step" +
             (group->distributed() ? " (split over " + std::to_string(group->world_size()) + " ranks)" : "") +
             ", Adam lr " + std::to_string(adam.lr()));
  }

  FinetuneLoop loop(o);
  loop.task = "finetune-decoder";
  loop.checkpoint = ckpt;
  loop.kind = "finetune-decoder";
  loop.resume_key = resume_key(o).dump();
  loop.resume_hint = "fields, model, batch, crop, weights, learning rate and seed";
  loop.steps = o.steps;
  loop.precision = ae->precision();
  loop.adam = &adam;
  loop.group = group.get();
  loop.step_loss = [&](int64_t step) {
    // Every rank draws the whole batch's crops from the step's generator and keeps its share.
    std::mt19937_64 rng(stream_seed(o.seed, SeedStream::stage3_crops, static_cast<uint64_t>(step)));
    // Crops drawn in the order training, held-out, round trip, so that a run without the round-trip term
    // draws what it always drew.
    std::vector<Stage3Term> terms;
    if (o.weight_train > 0) terms.push_back({"l1_train", o.weight_train, sample_crops(train, o.batch, crop, rng)});
    if (o.weight_novel > 0) terms.push_back({"l1_novel", o.weight_novel, sample_crops(novel, o.batch, crop, rng)});
    if (o.weight_roundtrip > 0) {
      auto crops = sample_crops(train, o.batch, crop, rng);
      {
        torch::NoGradGuard no_grad;
        crops.first = ae->encode(crops.second);
      }
      terms.push_back({"l1_roundtrip", o.weight_roundtrip, crops});
    }
    const std::vector<at::Tensor> losses = stage3_term_losses(*ae, terms, share, o.lambda_ssim);
    // The paper's two terms are always reported (0 when weighted out), the round trip only when it is used.
    FinetuneStepLoss step_loss{torch::zeros({}), {{"l1_train", 0.0}, {"l1_novel", 0.0}}};
    if (o.weight_roundtrip > 0) step_loss.metrics.push_back({"l1_roundtrip", 0.0});
    for (size_t i = 0; i < terms.size(); ++i) {
      step_loss.loss = step_loss.loss + terms[i].weight * losses[i];
      for (auto& [name, value] : step_loss.metrics)
        if (name == terms[i].metric) value = losses[i].item<double>();
    }
    return step_loss;
  };
  FinetuneLoopResult run = run_finetune_loop(loop);

  DecoderFinetuneResult r;
  r.main_rank = group->is_main();
  r.train_samples = static_cast<int64_t>(train.size());
  r.novel_samples = static_cast<int64_t>(novel.size());
  r.steps = run.steps;
  r.seconds = run.seconds;
  r.total_seconds = run.total_seconds;
  r.last_loss = run.last_loss;
  r.last_train = run.last_metrics["l1_train"];
  r.last_novel = run.last_metrics["l1_novel"];
  if (group->is_main()) {
    ae->save_decoder(o.out);
    nlohmann::json record = run_record(decoder_finetune_options_json(o));
    record["field_scenes"] = scenes;
    record["autoencoder_identity"] = autoencoder_identity(o.autoencoder, o.encoder);
    record["crop_used"] = crop;
    record["adam_lr"] = adam.lr();
    record["precision"] = precision_name(ae->precision());
    record["world_size"] = group->world_size();
    record["result"] = {{"steps", r.steps},
                        {"train_samples", r.train_samples},
                        {"novel_samples", r.novel_samples},
                        {"seconds", r.total_seconds},
                        {"seconds_this_session", r.seconds},
                        {"loss", r.last_loss},
                        {"l1_train", r.last_train},
                        {"l1_novel", r.last_novel}};
    write_json_file(decoder_record_path(o.out), record);
    log_info("wrote " + o.out + " and " + decoder_record_path(o.out));
  }
  finish_together(*group, o.out);
  return r;
}

}  // namespace lrf
