// Stage I: the batch sampler, the loss's properties, a tiny fine-tuning run that makes latents of a
// held-out scene more consistent, exact resume, and bad input.
#include <filesystem>

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "lrf/align/correspondence_loss.h"
#include "lrf/autoencoder/kl_vae.h"
#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/core/run_info.h"
#include "lrf/core/safetensors.h"
#include "lrf/finetune/consistency.h"
#include "lrf/finetune/encoder_finetune.h"
#include "test_helpers.h"

namespace fs = std::filesystem;
using lrf::test::error_of;

namespace {

std::string taef2() { return lrf::test::shared_dir() + "/models/taef2"; }
std::string train_scene() { return lrf::test::synthetic_scene(); }
std::string heldout_scene() { return lrf::test::synthetic_scene({8, "64x48", 11, 800}); }

lrf::PairScene pair_scene(const std::string& dir) { return lrf::load_pair_scene(dir, {}, 0, "", 15); }

lrf::EncoderFinetuneOptions tiny_options(const std::string& out) {
  lrf::EncoderFinetuneOptions o;
  o.scenes = {train_scene()};
  o.autoencoder = taef2();
  o.out = out;
  o.max_side = 0;
  o.batch.pairs = 2;
  o.batch.crop = 48;
  o.steps = 30;
  o.lr = 3e-4;
  o.checkpoint_every = 10;
  o.seed = 7;
  return o;
}

TEST(PairBatches, CropsKeepCorrespondencesAndAreReproducible) {
  std::vector<lrf::PairScene> scenes;
  scenes.push_back(pair_scene(train_scene()));
  lrf::PairBatchOptions bo;
  bo.pairs = 3;
  bo.crop = 40;
  lrf::PairBatch a = lrf::sample_pair_batch(scenes, bo, 1, 5);
  lrf::PairBatch b = lrf::sample_pair_batch(scenes, bo, 1, 5);
  lrf::PairBatch c = lrf::sample_pair_batch(scenes, bo, 1, 6);
  ASSERT_EQ(a.images.sizes(), (at::IntArrayRef{6, 3, 40, 40}));
  EXPECT_TRUE(torch::equal(a.images, b.images));
  EXPECT_FALSE(torch::equal(a.images, c.images));
  for (size_t k = 0; k < a.xi.size(); ++k) {
    EXPECT_GE(a.xi[k].size(0), bo.min_matches_in_crop);
    EXPECT_TRUE(torch::equal(a.xi[k], b.xi[k]));
    for (const auto& x : {a.xi[k], a.xj[k]}) {
      EXPECT_GE(x.min().item<float>(), 0.0f);
      EXPECT_LT(x.max().item<float>(), 40.0f);
    }
    EXPECT_GT(a.ape[k], 0.0);
  }
  // The synthetic scene's matches are exact projections of one textured surface point, so the crops'
  // colours (bilinear between pixel centres) agree far better at corresponding pixels than at unrelated ones.
  double matched = 0, shuffled = 0;
  for (size_t k = 0; k < a.xi.size(); ++k) {
    auto ci = lrf::sample_latent_at_pixels(a.images[2 * k], a.xi[k], 1);
    auto cj = lrf::sample_latent_at_pixels(a.images[2 * k + 1], a.xj[k], 1);
    matched += (ci - cj).abs().mean().item<double>();
    shuffled += (ci - cj.roll(7, 0)).abs().mean().item<double>();
  }
  std::printf("colour difference: matched %.4f, shuffled %.4f\n", matched, shuffled);
  EXPECT_LT(matched, 0.5 * shuffled);
}

TEST(Stage1Loss, ZeroForIdenticalViewsAndGradientOnlyInEncoder) {
  auto model = lrf::load_autoencoder(taef2());
  auto original = lrf::load_autoencoder(taef2());
  model->set_decoder_trainable(false);
  original->set_encoder_trainable(false);
  original->set_decoder_trainable(false);
  std::vector<lrf::PairScene> scenes;
  scenes.push_back(pair_scene(train_scene()));
  lrf::PairBatchOptions bo;
  bo.pairs = 1;
  bo.crop = 48;
  lrf::PairBatch batch = lrf::sample_pair_batch(scenes, bo, 0, 0);
  // Both halves of the pair are the same crop with the same points: every correspondence is exact.
  batch.images[1].copy_(batch.images[0]);
  batch.xj[0] = batch.xi[0].clone();
  lrf::EncoderFinetuneOptions o;
  lrf::Stage1Losses l = lrf::stage1_losses(*model, *original, batch, o);
  EXPECT_EQ(l.corres.item<double>(), 0.0);
  // The model is still the original, but the trainable copy encodes through libtorch's training
  // convolutions and the frozen one through the fused inference layers: the same sums in another order.
  // Bit-equal where both run the same kernels (seen on CPUs with native bf16); in fp32 elsewhere they
  // differ by float32 rounding through the encoder's layers, ~1e-6 of latents of order 1 (seen: a mean
  // square of 1.2e-12 on an AVX2 EPYC). 1e-9, an rms of 3e-5, bounds that rounding with room to spare
  // and is still a tiny fraction of the latents' own scale.
  EXPECT_LT(l.reg.item<double>(), 1e-9);
  EXPECT_GT(l.vae.item<double>(), 0.0);
  // A different pair has a positive correspondence loss whose gradient reaches the encoder only.
  lrf::PairBatch real = lrf::sample_pair_batch(scenes, bo, 0, 1);
  lrf::Stage1Losses m = lrf::stage1_losses(*model, *original, real, o);
  EXPECT_GT(m.corres.item<double>(), 0.0);
  m.total.backward();
  double encoder_grad = 0;
  for (const auto& p : model->encoder_parameters()) {
    if (p.grad().defined()) encoder_grad += p.grad().abs().sum().item<double>();
  }
  EXPECT_GT(encoder_grad, 0.0);
  for (const auto& p : model->decoder_parameters()) EXPECT_FALSE(p.grad().defined());
  for (const auto& p : original->encoder_parameters()) EXPECT_FALSE(p.grad().defined());
}

TEST(Stage1Loss, KLVaeUsesPosteriorKLAsRegulariser) {
  lrf::KLConfig c;
  c.ch = 32;
  c.ch_mult = {1, 1, 1, 1};
  c.num_res_blocks = 1;
  torch::manual_seed(0);
  lrf::KLAutoencoder model(c);
  lrf::KLAutoencoder original(c);
  // Same weights in both: the regulariser is KL(q || q) = 0 exactly.
  {
    torch::NoGradGuard no_grad;
    auto a = model.encoder_parameters(), b = original.encoder_parameters();
    for (size_t k = 0; k < a.size(); ++k) b[k].copy_(a[k]);
    auto ad = model.decoder_parameters(), bd = original.decoder_parameters();
    for (size_t k = 0; k < ad.size(); ++k) bd[k].copy_(ad[k]);
  }
  model.set_decoder_trainable(false);
  original.set_encoder_trainable(false);
  original.set_decoder_trainable(false);
  std::vector<lrf::PairScene> scenes;
  scenes.push_back(pair_scene(train_scene()));
  lrf::PairBatchOptions bo;
  bo.pairs = 1;
  bo.crop = 32;
  lrf::PairBatch batch = lrf::sample_pair_batch(scenes, bo, 0, 2);
  lrf::EncoderFinetuneOptions o;
  lrf::Stage1Losses l = lrf::stage1_losses(model, original, batch, o);
  EXPECT_NEAR(l.reg.item<double>(), 0.0, 1e-7);
  // Moving the fine-tuned encoder makes the KL positive, and the gradient stays in the encoder.
  {
    torch::NoGradGuard no_grad;
    for (auto& p : model.encoder_parameters()) p.add_(0.01 * torch::randn_like(p));
  }
  lrf::Stage1Losses m = lrf::stage1_losses(model, original, batch, o);
  EXPECT_GT(m.reg.item<double>(), 0.0);
  m.total.backward();
  for (const auto& p : model.decoder_parameters()) EXPECT_FALSE(p.grad().defined());
  double g = 0;
  for (const auto& p : model.encoder_parameters()) g += p.grad().defined() ? p.grad().abs().sum().item<double>() : 0.0;
  EXPECT_GT(g, 0.0);
}

// Stage I at each precision (bf16: bf16 compute on float32 master weights and Adam state).
class EncoderFinetuneAt : public ::testing::TestWithParam<lrf::Precision> {
 protected:
  lrf::test::ScopedPrecision precision_{GetParam()};
};
INSTANTIATE_TEST_SUITE_P(Precisions, EncoderFinetuneAt, ::testing::Values(lrf::Precision::fp32, lrf::Precision::bf16),
                         lrf::test::precision_param_name);

TEST_P(EncoderFinetuneAt, TinyRunMakesAHeldOutSceneMoreConsistent) {
  lrf::test::TempDir dir("stage1_tiny");
  lrf::EncoderFinetuneOptions o = tiny_options(dir / "enc.safetensors");
  auto result = lrf::finetune_encoder(o);
  ASSERT_TRUE(fs::exists(o.out));
  ASSERT_TRUE(fs::exists(lrf::finetune_record_path(o.out)));
  nlohmann::json record = lrf::read_json_file(lrf::finetune_record_path(o.out));
  EXPECT_EQ(record.value("precision", ""), lrf::precision_name(GetParam()));
  std::printf("%s: last loss %.5f (vae %.5f, corres %.5f, reg %.6f)\n", lrf::precision_name(GetParam()).c_str(),
              result.last_total, result.last_vae, result.last_corres, result.last_reg);

  lrf::PairScene heldout = pair_scene(heldout_scene());
  auto stock = lrf::load_autoencoder(taef2());
  auto tuned = lrf::load_autoencoder(taef2(), o.out);
  lrf::ConsistencyReport before = lrf::measure_consistency(heldout, *stock);
  lrf::ConsistencyReport after = lrf::measure_consistency(heldout, *tuned);
  std::printf("held-out synthetic: corr %.4f -> %.4f, relative %.4f -> %.4f, round trip %.2f -> %.2f dB, HF %.4f -> %.4f\n",
              before.correspondence_l1, after.correspondence_l1, before.correspondence_relative,
              after.correspondence_relative, before.roundtrip_psnr, after.roundtrip_psnr,
              before.high_frequency_share, after.high_frequency_share);
  EXPECT_LT(after.correspondence_relative, 0.9 * before.correspondence_relative);
  EXPECT_LT(after.correspondence_l1, 0.9 * before.correspondence_l1);
  EXPECT_GT(after.roundtrip_psnr, before.roundtrip_psnr - 2.0);
}

TEST_P(EncoderFinetuneAt, ResumedRunEqualsUninterruptedRun) {
  lrf::test::TempDir dir("stage1_resume");
  lrf::EncoderFinetuneOptions straight = tiny_options(dir / "straight.safetensors");
  straight.steps = 6;
  straight.checkpoint_every = 3;
  lrf::finetune_encoder(straight);

  lrf::EncoderFinetuneOptions first = straight;
  first.out = dir / "resumed.safetensors";
  first.steps = 3;  // stops after its checkpoint at step 3, as a killed run would have left it
  lrf::finetune_encoder(first);
  // The checkpoint carries the wall time of the steps so far, and the resumed run's record adds its own.
  const double at_checkpoint =
      std::stod(lrf::read_safetensors_metadata(lrf::finetune_checkpoint_path(first.out)).at("lrf_seconds"));
  EXPECT_GT(at_checkpoint, 0.0);
  EXPECT_LE(at_checkpoint, lrf::read_json_file(lrf::finetune_record_path(first.out))["result"]["seconds"].get<double>());
  lrf::EncoderFinetuneOptions second = first;
  second.steps = 6;
  second.resume = true;
  lrf::finetune_encoder(second);
  const nlohmann::json result = lrf::read_json_file(lrf::finetune_record_path(second.out))["result"];
  EXPECT_NEAR(result["seconds"].get<double>(), at_checkpoint + result["seconds_this_session"].get<double>(), 0.01);

  lrf::StateDict a = lrf::read_safetensors(straight.out), b = lrf::read_safetensors(second.out);
  ASSERT_EQ(a.size(), b.size());
  for (size_t k = 0; k < a.size(); ++k) EXPECT_TRUE(torch::equal(a[k].value(), b[k].value())) << a[k].key();
  // The weights stay float32 at either precision; the checkpoint names the precision its steps ran at.
  for (size_t k = 0; k < b.size(); ++k) EXPECT_EQ(b[k].value().scalar_type(), at::kFloat) << b[k].key();
  EXPECT_EQ(lrf::read_safetensors_metadata(lrf::finetune_checkpoint_path(second.out))["lrf_precision"],
            lrf::precision_name(GetParam()));

  // Resuming with other options is refused rather than mixing two runs.
  lrf::EncoderFinetuneOptions other = second;
  other.lambda_corres = 2.0;
  other.steps = 8;
  EXPECT_NE(error_of([&] { lrf::finetune_encoder(other); }).find("different options"), std::string::npos);
}

TEST(EncoderFinetune, BadInputIsReported) {
  lrf::test::TempDir dir("stage1_bad");
  lrf::EncoderFinetuneOptions o = tiny_options(dir / "enc.safetensors");
  o.min_matches = 100000;
  EXPECT_NE(error_of([&] { lrf::finetune_encoder(o); }).find("no view pair"), std::string::npos);

  fs::create_directories(dir / "no_poses/images");
  fs::copy_file(train_scene() + "/images/" + fs::directory_iterator(train_scene() + "/images")->path().filename().string(),
                dir / "no_poses/images/a.png");
  o = tiny_options(dir / "enc.safetensors");
  o.scenes = {dir / "no_poses"};
  EXPECT_NE(error_of([&] { lrf::finetune_encoder(o); }).find("no_poses"), std::string::npos);

  o = tiny_options(dir / "enc.safetensors");
  o.correspondence_files = {"a", "b"};
  EXPECT_NE(error_of([&] { lrf::finetune_encoder(o); }).find("one per scene"), std::string::npos);

  o = tiny_options(dir / "enc.safetensors");
  o.resume = true;
  EXPECT_NE(error_of([&] { lrf::finetune_encoder(o); }).find("no checkpoint"), std::string::npos);
  EXPECT_FALSE(fs::exists(o.out));

  // An existing output is kept unless --force.
  o = tiny_options(dir / "taken.safetensors");
  lrf::write_file_atomic(o.out, "someone's file");
  EXPECT_NE(error_of([&] { lrf::finetune_encoder(o); }).find("already exists"), std::string::npos);
  EXPECT_EQ(lrf::read_file(o.out), "someone's file");

  auto r = lrf::test::run_lrf("finetune-encoder --scenes " + (dir / "missing") + " -o " + (dir / "x.safetensors"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("missing"), std::string::npos);
}

// The command line takes lrf pipeline's per-scene resolutions (PATH:--images=DIR) and records them as the
// pipeline's Stage I does; a bad one is a usage error before any work.
TEST(EncoderFinetune, CommandLineTakesPerSceneResolutions) {
  lrf::test::TempDir dir("stage1_spec");
  const std::string common = " --autoencoder " + taef2() + " --max-side 0 --crop 48 --steps 2 --lr 3e-4 -o ";
  auto r = lrf::test::run_lrf("finetune-encoder --scenes " + train_scene() + ":--images=images" + common +
                              (dir / "enc.safetensors"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto record = lrf::read_json_file(dir / "enc.json");
  EXPECT_EQ(record["options"]["scenes"], nlohmann::json::array({train_scene()}));
  EXPECT_EQ(record["options"]["scene_resolutions"], nlohmann::json::parse(R"([{"downscale": 0, "images": "images"}])"));

  r = lrf::test::run_lrf("finetune-encoder --scenes " + train_scene() + ":--imgs=images" + common + (dir / "bad.safetensors"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--imgs"), std::string::npos) << r.output;
  r = lrf::test::run_lrf("finetune-encoder --scenes " + train_scene() + ":--images=nowhere" + common +
                         (dir / "bad.safetensors"));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("nowhere"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "bad.safetensors"));
}

}  // namespace
