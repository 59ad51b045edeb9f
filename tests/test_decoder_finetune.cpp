// Stage III: fine-tuning the decoder on rendered latents lowers the L1 of decoded renders on held-out
// views of a scene it never saw; resume is exact; bad input is reported.
#include <filesystem>

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "lrf/autoencoder/autoencoder.h"
#include "lrf/autoencoder/image_tensor.h"
#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/core/run_info.h"
#include "lrf/core/safetensors.h"
#include "lrf/latent/latent_run.h"
#include "lrf/latent/latent_train_run.h"
#include "lrf/finetune/decoder_finetune.h"
#include "lrf/finetune/stage3_terms.h"
#include "test_helpers.h"

namespace fs = std::filesystem;
using lrf::test::error_of;

namespace {

std::string taef2() { return lrf::test::shared_dir() + "/models/taef2"; }

// A latent field on a 16-view synthetic scene, trained once per test process.
std::string field(const std::string& root, unsigned seed) {
  const std::string out = root + "/field_" + std::to_string(seed);
  if (fs::exists(out + "/point_cloud.ply")) return out;
  lrf::LatentTrainOptions o;
  o.scene = lrf::test::synthetic_scene({16, "128x96", seed, 1500});
  o.out = out;
  o.autoencoder = taef2();
  o.iters = 300;
  o.cache_dir = root + "/cache";
  lrf::train_latent_field(o);
  return out;
}

// Mean L1 between `decoded(autoencoder, run, view, image)` and the real image over a field's held-out
// views, with `decoder` in place of the autoencoder's own.
template <typename Decoded>
double heldout_mean_l1(const std::string& field_dir, const std::string& decoder, Decoded decoded) {
  torch::NoGradGuard no_grad;
  lrf::LatentRun run = lrf::open_latent_run(field_dir);
  auto ae = lrf::load_autoencoder(taef2(), "", decoder);
  double sum = 0;
  for (int i : run.scene.test_indices) {
    const at::Tensor image = lrf::image_to_batch(run.scene.load_image(i));
    const at::Tensor reconstruction = decoded(*ae, run, i, image);
    sum += (reconstruction - image).abs().mean().item<double>();
  }
  return sum / run.scene.test_indices.size();
}

// Decoded rendered latents against the real images.
double heldout_l1(const std::string& field_dir, const std::string& decoder) {
  return heldout_mean_l1(field_dir, decoder,
                         [](lrf::Autoencoder& ae, const lrf::LatentRun& run, int i, const at::Tensor&) {
                           return ae.decode(run.range.denormalize(lrf::render_latent(run, i)).unsqueeze(0));
                         });
}

class DecoderFinetune : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { dir_ = new lrf::test::TempDir("stage3"); }
  static void TearDownTestSuite() { delete dir_; }
  static lrf::test::TempDir* dir_;
  lrf::DecoderFinetuneOptions options(const std::string& out) const {
    lrf::DecoderFinetuneOptions o;
    o.fields = {field(dir_->str(), 7)};
    o.autoencoder = taef2();
    o.out = out;
    o.steps = 20;
    o.crop = 64;
    o.lr = 3e-4;
    o.checkpoint_every = 10;
    return o;
  }
};
lrf::test::TempDir* DecoderFinetune::dir_ = nullptr;

TEST_F(DecoderFinetune, LowersHeldOutL1OnAnUnseenScene) {
  lrf::DecoderFinetuneOptions o = options(*dir_ / "dec.safetensors");
  auto r = lrf::finetune_decoder(o);
  EXPECT_EQ(r.novel_samples, 2);  // views 0 and 8 of 16 are held out
  const std::string unseen = field(dir_->str(), 13);
  const double stock = heldout_l1(unseen, ""), tuned = heldout_l1(unseen, o.out);
  std::printf("held-out views of an unseen synthetic scene: L1 %.5f (stock decoder) -> %.5f (fine-tuned)\n", stock, tuned);
  EXPECT_LT(tuned, 0.97 * stock);
  // Only the decoder is written; its record names the fields' scenes.
  auto tensors = lrf::read_safetensors(o.out);
  for (const auto& item : tensors) EXPECT_EQ(item.key().find("encoder"), std::string::npos) << item.key();
}

// The D-SSIM mix (a lever of Stage III's loss): it changes the updates, still lowers the held-out L1 of an
// unseen scene, and is recorded only when used, so that records of the paper's pure L1 stay as they were.
TEST_F(DecoderFinetune, SsimMixIsRecordedOnlyWhenUsedAndStillLowersHeldOutL1) {
  lrf::DecoderFinetuneOptions l1 = options(*dir_ / "mix-l1.safetensors");
  l1.steps = 3;
  lrf::finetune_decoder(l1);
  lrf::DecoderFinetuneOptions mix = options(*dir_ / "mix-ssim.safetensors");
  mix.lambda_ssim = 0.5;
  lrf::finetune_decoder(mix);
  EXPECT_FALSE(lrf::read_json_file(lrf::decoder_record_path(l1.out))["options"].contains("lambda_ssim"));
  EXPECT_EQ(lrf::read_json_file(lrf::decoder_record_path(mix.out))["options"]["lambda_ssim"], 0.5);
  // The first three steps draw the same crops; the mixed loss moves the weights elsewhere.
  lrf::DecoderFinetuneOptions mix3 = options(*dir_ / "mix-ssim3.safetensors");
  mix3.steps = 3;
  mix3.lambda_ssim = 0.5;
  lrf::finetune_decoder(mix3);
  auto a = lrf::read_safetensors(l1.out), b = lrf::read_safetensors(mix3.out);
  ASSERT_EQ(a.size(), b.size());
  bool differ = false;
  for (size_t k = 0; k < a.size(); ++k) differ = differ || !torch::equal(a[k].value(), b[k].value());
  EXPECT_TRUE(differ);
  const std::string unseen = field(dir_->str(), 13);
  EXPECT_LT(heldout_l1(unseen, mix.out), 0.97 * heldout_l1(unseen, ""));
  lrf::DecoderFinetuneOptions bad = options(*dir_ / "mix-bad.safetensors");
  bad.lambda_ssim = 1.5;
  EXPECT_NE(error_of([&] { lrf::finetune_decoder(bad); }).find("--lambda-ssim"), std::string::npos);
}

// The encode-decode round trip of the real images.
double heldout_roundtrip_l1(const std::string& field_dir, const std::string& decoder) {
  return heldout_mean_l1(field_dir, decoder,
                         [](lrf::Autoencoder& ae, const lrf::LatentRun&, int, const at::Tensor& image) {
                           return ae.decode(ae.encode(image));
                         });
}

// The round-trip term (encoded training images beside the rendered latents) keeps the decoder decoding
// ordinary latents: an unseen scene's encode-decode round trip suffers less than under the paper's loss
// alone; and it is recorded only when used.
TEST_F(DecoderFinetune, RoundTripTermKeepsTheDecoderDecodingEncodedLatents) {
  lrf::DecoderFinetuneOptions plain = options(*dir_ / "rt-plain.safetensors");
  lrf::finetune_decoder(plain);
  lrf::DecoderFinetuneOptions kept = options(*dir_ / "rt-kept.safetensors");
  kept.weight_roundtrip = 1.0;
  lrf::finetune_decoder(kept);
  EXPECT_FALSE(lrf::read_json_file(lrf::decoder_record_path(plain.out))["options"].contains("weight_roundtrip"));
  EXPECT_EQ(lrf::read_json_file(lrf::decoder_record_path(kept.out))["options"]["weight_roundtrip"], 1.0);
  const std::string unseen = field(dir_->str(), 13);
  const double stock = heldout_roundtrip_l1(unseen, ""), l1_only = heldout_roundtrip_l1(unseen, plain.out),
               with_term = heldout_roundtrip_l1(unseen, kept.out);
  std::printf("round-trip L1 on an unseen scene: %.5f stock, %.5f paper's loss, %.5f with the term\n", stock,
              l1_only, with_term);
  EXPECT_LT(with_term, l1_only);
  lrf::DecoderFinetuneOptions bad = options(*dir_ / "rt-bad.safetensors");
  bad.weight_roundtrip = -1;
  EXPECT_NE(error_of([&] { lrf::finetune_decoder(bad); }).find("--weight-roundtrip"), std::string::npos);
}

// A step's terms decoded as one stacked batch give each term the loss, and the decoder the gradient, that
// decoding each term apart gives, whole or as one rank's share of the batch. Tolerances: the two ways differ
// only in the order float32 sums are taken (a mean over 2 x 3 x 64 x 64 pixels, weight gradients summed over
// the batch), about 1e-6 relative; a term scored against another term's crops is off by tens of percent.
TEST(Stage3Terms, OneStackedPassEqualsEachTermDecodedApart) {
  lrf::test::ScopedPrecision fp32{lrf::Precision::fp32};
  auto ae = lrf::load_autoencoder(taef2());
  ae->set_decoder_trainable(true);
  const std::vector<at::Tensor> params = ae->decoder_parameters();
  torch::manual_seed(3);
  std::vector<lrf::Stage3Term> terms;
  for (const char* name : {"l1_train", "l1_novel", "l1_roundtrip"})
    terms.push_back({name, 0.5, {torch::randn({2, 32, 8, 8}), torch::rand({2, 3, 64, 64})}});
  for (int world : {1, 2}) {
    const lrf::BatchShare share = lrf::batch_share(2, world - 1, world);
    auto gradients = [&](const at::Tensor& loss) {
      for (const at::Tensor& p : params) p.mutable_grad() = at::Tensor();
      loss.backward();
      std::vector<at::Tensor> g;
      for (const at::Tensor& p : params) g.push_back(p.grad().clone());
      return g;
    };
    const std::vector<at::Tensor> stacked = lrf::stage3_term_losses(*ae, terms, share, 0);
    ASSERT_EQ(stacked.size(), terms.size());
    at::Tensor stacked_loss = torch::zeros({});
    for (size_t i = 0; i < terms.size(); ++i) stacked_loss = stacked_loss + terms[i].weight * stacked[i];
    const std::vector<at::Tensor> g_stacked = gradients(stacked_loss);
    at::Tensor apart_loss = torch::zeros({});
    for (size_t i = 0; i < terms.size(); ++i) {
      const at::Tensor z = terms[i].crops.first.narrow(0, share.first, share.count);
      const at::Tensor x = terms[i].crops.second.narrow(0, share.first, share.count);
      const at::Tensor l = (ae->decode_unclamped(z) - x).abs().mean() * lrf::share_weight(share);
      EXPECT_NEAR(stacked[i].item<double>(), l.item<double>(), 1e-5 * l.item<double>()) << terms[i].metric;
      apart_loss = apart_loss + terms[i].weight * l;
    }
    const std::vector<at::Tensor> g_apart = gradients(apart_loss);
    for (size_t k = 0; k < params.size(); ++k) {
      const double scale = g_apart[k].abs().max().item<double>();
      EXPECT_LE((g_stacked[k] - g_apart[k]).abs().max().item<double>(), 1e-4 * scale + 1e-12)
          << "parameter " << k << ", world " << world;
    }
  }
}

// Stage III at each precision (bf16: bf16 compute on float32 master weights and Adam state).
class DecoderFinetuneAt : public DecoderFinetune, public ::testing::WithParamInterface<lrf::Precision> {
 protected:
  lrf::test::ScopedPrecision precision_{GetParam()};
};
INSTANTIATE_TEST_SUITE_P(Precisions, DecoderFinetuneAt, ::testing::Values(lrf::Precision::fp32, lrf::Precision::bf16),
                         lrf::test::precision_param_name);

TEST_P(DecoderFinetuneAt, ResumedRunEqualsUninterruptedRun) {
  // The suite's folder is shared by both precisions: each writes its own files.
  const std::string tag = lrf::precision_name(GetParam());
  lrf::DecoderFinetuneOptions straight = options(*dir_ / ("straight-" + tag + ".safetensors"));
  straight.steps = 4;
  straight.checkpoint_every = 2;
  lrf::finetune_decoder(straight);
  lrf::DecoderFinetuneOptions first = straight;
  first.out = *dir_ / ("resumed-" + tag + ".safetensors");
  first.steps = 2;
  lrf::finetune_decoder(first);
  lrf::DecoderFinetuneOptions second = first;
  second.steps = 4;
  second.resume = true;
  lrf::finetune_decoder(second);
  auto a = lrf::read_safetensors(straight.out), b = lrf::read_safetensors(second.out);
  ASSERT_EQ(a.size(), b.size());
  for (size_t k = 0; k < a.size(); ++k) EXPECT_TRUE(torch::equal(a[k].value(), b[k].value())) << a[k].key();
  // The weights stay float32 at either precision; the checkpoint names the precision its steps ran at.
  for (size_t k = 0; k < b.size(); ++k) EXPECT_EQ(b[k].value().scalar_type(), at::kFloat) << b[k].key();
  EXPECT_EQ(lrf::read_safetensors_metadata(lrf::decoder_checkpoint_path(second.out))["lrf_precision"],
            lrf::precision_name(GetParam()));
}

TEST_F(DecoderFinetune, BadInputIsReported) {
  lrf::DecoderFinetuneOptions o = options(*dir_ / "bad.safetensors");
  // A folder that is no run says so; a run of another kind names its kind.
  o.fields = {dir_->str()};
  EXPECT_NE(error_of([&] { lrf::finetune_decoder(o); }).find("config.json: not found"), std::string::npos);
  fs::create_directories(*dir_ / "rgb_run");
  lrf::write_file_atomic(*dir_ / "rgb_run/config.json", R"({"space": "rgb"})");
  o.fields = {*dir_ / "rgb_run"};
  EXPECT_NE(error_of([&] { lrf::finetune_decoder(o); }).find("holds a field of space 'rgb', not a latent field"), std::string::npos);
  o = options(*dir_ / "bad.safetensors");
  o.encoder = *dir_ / "missing_encoder.safetensors";
  EXPECT_FALSE(error_of([&] { lrf::finetune_decoder(o); }).empty());
  o = options(*dir_ / "bad.safetensors");
  o.fields.clear();
  EXPECT_NE(error_of([&] { lrf::finetune_decoder(o); }).find("--fields"), std::string::npos);
  EXPECT_FALSE(fs::exists(*dir_ / "bad.safetensors"));
  // An existing output is kept unless --force; --resume needs a checkpoint.
  o = options(*dir_ / "taken.safetensors");
  lrf::write_file_atomic(o.out, "someone's file");
  EXPECT_NE(error_of([&] { lrf::finetune_decoder(o); }).find("already exists"), std::string::npos);
  o.resume = true;
  EXPECT_NE(error_of([&] { lrf::finetune_decoder(o); }).find("no checkpoint"), std::string::npos);
  EXPECT_EQ(lrf::read_file(o.out), "someone's file");
}

}  // namespace
