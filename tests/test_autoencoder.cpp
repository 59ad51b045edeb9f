#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "test_helpers.h"
#include <torch/torch.h>

#include "lrf/autoencoder/autoencoder.h"
#include "lrf/autoencoder/image_tensor.h"
#include "lrf/eval/metrics.h"
#include "lrf/autoencoder/kl_vae.h"
#include "lrf/autoencoder/resolve.h"
#include "lrf/autoencoder/tiny_ae.h"
#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/core/safetensors.h"
#include "reference_helper.h"

namespace fs = std::filesystem;

namespace {

// fp32 agreement bound for the PyTorch comparison. Both sides run the same fp32 convolutions through
// oneDNN/BLAS with different summation orders; over ~20 conv layers that leaves differences of ~1e-5
// relative to activations of order 1-10, so 1e-3 (the bound) catches any real mismatch (a wrong
// layer, key or padding changes outputs by >1e-2) while tolerating reassociation.
constexpr double kTolerance = 1e-3;

std::string taef2_dir() { return lrf_test::shared_dir() + "/models/taef2"; }

std::string first_fern_image() {
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(lrf_test::shared_dir() + "/scenes/llff-fern/images_8")) {
    if (e.path().extension() == ".png") files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());
  if (files.empty()) throw std::runtime_error("no fern images");
  return files.front();
}

double max_abs(const at::Tensor& a, const at::Tensor& b) { return (a - b).abs().max().item<double>(); }

using lrf::test::error_of;

}  // namespace

TEST(TinyAutoencoder, Taef2MatchesPyTorchOnRealImage) {
  torch::NoGradGuard no_grad;
  auto ae = lrf::load_autoencoder(taef2_dir());
  EXPECT_EQ(ae->kind(), "tiny");
  EXPECT_EQ(ae->latent_channels(), 32);
  cv::Mat image = lrf::center_crop_to_multiple(lrf::read_image_rgb(first_fern_image()), 8);
  ASSERT_EQ(image.cols, 504);
  ASSERT_EQ(image.rows, 376);
  at::Tensor x = lrf::image_to_batch(image);

  // The input goes to a path named after its content, so that the PyTorch output can be cached.
  const std::string input_path = lrf_test::fixture_input("taef2", x);
  fs::path dir = lrf_test::cached_fixture("taef2", "taef2 --weights " + taef2_dir() + " --input " + input_path);
  ASSERT_FALSE(dir.empty());
  auto ref = lrf::read_safetensors((dir / "ref.safetensors").string());

  at::Tensor z = ae->encode(x);
  ASSERT_EQ(z.sizes(), (std::vector<int64_t>{1, 32, 47, 63}));
  at::Tensor y = ae->decode(z);
  ASSERT_EQ(y.sizes(), x.sizes());
  double dz = max_abs(z, ref["latent"]), dy = max_abs(y, ref["decoded"]);
  std::printf("TAEF2 vs PyTorch: latent max abs diff %.3g, decoded max abs diff %.3g\n", dz, dy);
  EXPECT_LE(dz, kTolerance);
  EXPECT_LE(dy, kTolerance);
  // The reconstruction itself is sane (the full 20-view figure is measured by `lrf ae roundtrip`).
  EXPECT_GT(lrf::psnr(y.squeeze(0), x.squeeze(0)), 20.0);
}

class KLReference : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = lrf_test::cached_fixture("kl", "kl --ch 32 --size 64");
    ok_ = !dir_.empty();
  }
  void SetUp() override { ASSERT_TRUE(ok_) << "fixture generation failed (see the message above)"; }
  static std::string path(const std::string& name) { return (dir_ / name).string(); }

  static void compare(const std::string& file) {
    torch::NoGradGuard no_grad;
    auto ae = lrf::load_autoencoder(path(file));
    ASSERT_EQ(ae->kind(), "kl-f8");
    ASSERT_EQ(ae->latent_channels(), 4);
    auto& kl = dynamic_cast<lrf::KLAutoencoder&>(*ae);
    EXPECT_EQ(kl.config().ch, 32);
    EXPECT_EQ(kl.config().ch_mult, (std::vector<int>{1, 2, 4, 4}));
    EXPECT_EQ(kl.config().num_res_blocks, 2);
    auto ref = lrf::read_safetensors(path("reference.safetensors"));
    at::Tensor moments = kl.encode_moments(ref["image"]);
    at::Tensor mean = ae->encode(ref["image"]);
    at::Tensor decoded = ae->decode(mean);
    double dm = max_abs(moments, ref["moments"]), dd = max_abs(decoded, ref["decoded"]);
    std::printf("KL-VAE %s vs PyTorch: moments max abs diff %.3g, decoded %.3g\n", file.c_str(), dm, dd);
    EXPECT_LE(dm, kTolerance);
    EXPECT_LE(dd, kTolerance);
    // The decoded image is not trivially saturated (the comparison would then be vacuous).
    EXPECT_GT(decoded.std().item<double>(), 0.01);
  }
  static fs::path dir_;
  static bool ok_;
};
fs::path KLReference::dir_;
bool KLReference::ok_ = false;

TEST_F(KLReference, LdmSafetensorsMatchesPyTorch) { compare("kl_ldm.safetensors"); }
TEST_F(KLReference, LdmCkptWithPrefixMatchesPyTorch) { compare("kl_ldm.ckpt"); }
TEST_F(KLReference, DiffusersSafetensorsMatchesPyTorch) { compare("kl_diffusers.safetensors"); }
TEST_F(KLReference, DiffusersCkptOldAttentionNamesMatchesPyTorch) { compare("kl_diffusers.ckpt"); }

TEST_F(KLReference, SampleIsMeanPlusScaledNoise) {
  torch::NoGradGuard no_grad;
  auto ae = lrf::load_autoencoder(path("kl_ldm.safetensors"));
  auto ref = lrf::read_safetensors(path("reference.safetensors"));
  torch::manual_seed(3);
  at::Tensor s = ae->encode_sample(ref["image"]);
  at::Tensor mean = ref["moments"].narrow(1, 0, 4), std = torch::exp(0.5 * ref["moments"].narrow(1, 4, 4));
  at::Tensor noise = (s - mean) / std;
  // Standardised noise: mean ~0, std ~1 over 4*8*8 = 256 samples (loose bounds: 5 standard errors).
  EXPECT_LT(std::abs(noise.mean().item<double>()), 0.35);
  EXPECT_NEAR(noise.std().item<double>(), 1.0, 0.3);
}

TEST_F(KLReference, SaveAndReloadHalvesRoundTrip) {
  torch::NoGradGuard no_grad;
  auto ae = lrf::load_autoencoder(path("kl_diffusers.safetensors"));
  auto own = lrf_test::fresh_dir("kl_halves");  // the shared fixture folder stays read-only
  std::string enc = (own / "enc.safetensors").string(), dec = (own / "dec.safetensors").string();
  ae->save_encoder(enc);
  ae->save_decoder(dec);
  auto fresh = std::make_unique<lrf::KLAutoencoder>(dynamic_cast<lrf::KLAutoencoder&>(*ae).config());
  fresh->load_encoder(enc);
  fresh->load_decoder(dec);
  fresh->set_channels_last(ae->channels_last());  // same kernels, so equal weights give equal outputs
  auto ref = lrf::read_safetensors(path("reference.safetensors"));
  EXPECT_TRUE(torch::equal(fresh->encode(ref["image"]), ae->encode(ref["image"])));
  // Overrides through the factory: the ldm file with the saved halves swapped in.
  auto over = lrf::load_autoencoder(path("kl_ldm.safetensors"), enc, dec);
  EXPECT_TRUE(torch::equal(over->decode(over->encode(ref["image"])), ae->decode(ae->encode(ref["image"]))));
  fs::remove_all(own);
}

TEST(KLAutoencoder, StrictLoadingListsMissingUnexpectedAndMisshapedKeys) {
  lrf::KLConfig cfg;
  cfg.ch = 32;
  lrf::KLAutoencoder ae(cfg);
  lrf::StateDict sd;
  for (const auto& item : ae.encoder_state()) sd.insert(item.key(), item.value());
  for (const auto& item : ae.decoder_state()) sd.insert(item.key(), item.value());
  lrf::StateDict broken;
  for (const auto& item : sd) {
    if (item.key() == "decoder.up.1.block.2.conv2.bias") continue;  // missing
    at::Tensor v = item.value();
    if (item.key() == "encoder.mid.attn_1.q.weight") v = v.reshape({v.size(0), v.size(1)}).t().reshape({-1});
    broken.insert(item.key(), v);
  }
  broken.insert("decoder.extra_layer.weight", torch::zeros({3}));
  auto dir = lrf_test::fresh_dir("kl_strict");
  std::string file = (dir / "broken.safetensors").string();
  lrf::write_safetensors(file, broken);
  std::string msg = error_of([&] { lrf::load_autoencoder(file); });
  EXPECT_NE(msg.find("broken.safetensors"), std::string::npos) << msg;
  EXPECT_NE(msg.find("missing 1 keys: decoder.up.1.block.2.conv2.bias"), std::string::npos) << msg;
  EXPECT_NE(msg.find("unexpected 1 keys: decoder.extra_layer.weight"), std::string::npos) << msg;
  EXPECT_NE(msg.find("wrong shape: encoder.mid.attn_1.q.weight [16384]"), std::string::npos) << msg;
  fs::remove_all(dir);
}

TEST(TinyAutoencoder, WrongArchitectureForWeightsIsAnError) {
  auto ae = lrf::load_autoencoder(taef2_dir());
  // Decoder weights offered as an encoder.
  std::string msg = error_of([&] { ae->load_encoder(taef2_dir() + "/taef2_decoder.pth"); });
  EXPECT_NE(msg.find("taef2_decoder.pth (tiny encoder)"), std::string::npos) << msg;
  EXPECT_NE(msg.find("missing"), std::string::npos) << msg;
  // KL-VAE weights offered to a tiny decoder.
  lrf::KLConfig cfg;
  cfg.ch = 32;
  lrf::KLAutoencoder kl(cfg);
  auto dir = lrf_test::fresh_dir("tiny_wrong");
  kl.save_decoder((dir / "kl_dec.safetensors").string());
  msg = error_of([&] { ae->load_decoder((dir / "kl_dec.safetensors").string()); });
  EXPECT_NE(msg.find("unexpected"), std::string::npos) << msg;
  EXPECT_NE(msg.find("decoder.conv_in.weight"), std::string::npos) << msg;
  // A tiny checkpoint is not a KL-VAE and vice versa: a 16-channel TAESD latent to a 32-channel decoder.
  msg = error_of([&] { ae->decode(torch::zeros({1, 16, 8, 8})); });
  EXPECT_NE(msg.find("[B,32,h,w]"), std::string::npos) << msg;
  fs::remove_all(dir);
}

TEST(TinyAutoencoder, ImagesNotMultipleOf8AreRefusedAndCropHelperCentres) {
  lrf::TinyAutoencoder ae(4, false);
  std::string msg = error_of([&] { ae.encode(torch::zeros({1, 3, 30, 64})); });
  EXPECT_NE(msg.find("multiples of 8"), std::string::npos) << msg;
  cv::Mat m(30, 21, CV_32FC3);
  for (int y = 0; y < m.rows; ++y)
    for (int x = 0; x < m.cols; ++x) m.at<cv::Vec3f>(y, x) = cv::Vec3f(static_cast<float>(x), static_cast<float>(y), 0);
  cv::Mat c = lrf::center_crop_to_multiple(m, 8);
  ASSERT_EQ(c.cols, 16);
  ASSERT_EQ(c.rows, 24);
  EXPECT_EQ(c.at<cv::Vec3f>(0, 0)[0], 2.0f);  // (21-16)/2 = 2 columns dropped on the left
  EXPECT_EQ(c.at<cv::Vec3f>(0, 0)[1], 3.0f);  // (30-24)/2 = 3 rows dropped at the top
  EXPECT_THROW(lrf::center_crop_to_multiple(cv::Mat(7, 40, CV_32FC3), 8), lrf::Error);
}

TEST(TinyAutoencoder, FourAndSixteenChannelVariantsRoundTripThroughFiles) {
  auto dir = lrf_test::fresh_dir("tiny_variants");
  for (int c : {4, 16}) {
    lrf::TinyAutoencoder ae(c, false);
    ae.save_encoder((dir / "tiny_encoder.safetensors").string());
    ae.save_decoder((dir / "tiny_decoder.safetensors").string());
    auto back = lrf::load_autoencoder(dir.string());  // folder with *encoder* / *decoder* files
    EXPECT_EQ(back->latent_channels(), c);
    // Same layout on both sides, so that equal weights give bitwise-equal outputs.
    EXPECT_TRUE(back->channels_last());
    back->set_channels_last(false);
    torch::NoGradGuard no_grad;
    at::Tensor x = torch::rand({1, 3, 32, 48});
    EXPECT_TRUE(torch::equal(back->decode(back->encode(x)), ae.decode(ae.encode(x))));
    EXPECT_EQ(ae.encode(x).sizes(), (std::vector<int64_t>{1, c, 4, 6}));
  }
  fs::remove_all(dir);
}

TEST(TinyAutoencoder, DiffusersSingleFileLayoutLoads) {
  // diffusers' AutoencoderTiny single file: "encoder.layers.N.*" and "decoder.layers.N.*", the decoder
  // numbered without the leading clamp (layers.0 is our index 1).
  lrf::StateDict enc = lrf::load_state_dict(taef2_dir() + "/taef2_encoder.pth");
  lrf::StateDict dec = lrf::load_state_dict(taef2_dir() + "/taef2_decoder.pth");
  lrf::StateDict single;
  for (const auto& item : enc) single.insert("encoder.layers." + item.key(), item.value());
  for (const auto& item : dec) {
    auto dot = item.key().find('.');
    int index = std::stoi(item.key().substr(0, dot));
    single.insert("decoder.layers." + std::to_string(index - 1) + item.key().substr(dot), item.value());
  }
  auto dir = lrf_test::fresh_dir("tiny_single");
  std::string file = (dir / "taef2.safetensors").string();
  lrf::write_safetensors(file, single);
  torch::NoGradGuard no_grad;
  auto a = lrf::load_autoencoder(file), b = lrf::load_autoencoder(taef2_dir());
  at::Tensor x = torch::rand({1, 3, 32, 32});
  EXPECT_TRUE(torch::equal(a->decode(a->encode(x)), b->decode(b->encode(x))));
  fs::remove_all(dir);
}

TEST(Resolve, FindsByNameInLrfModelsAndReportsWhereItLooked) {
  ::setenv("LRF_MODELS", (lrf_test::shared_dir() + "/models").c_str(), 1);
  auto files = lrf::resolve_autoencoder("taef2");
  EXPECT_NE(files.encoder.find("taef2_encoder.pth"), std::string::npos);
  EXPECT_NE(files.decoder.find("taef2_decoder.pth"), std::string::npos);
  std::string msg = error_of([] { lrf::resolve_autoencoder("no-such-model"); });
  EXPECT_NE(msg.find("not found"), std::string::npos) << msg;
  EXPECT_NE(msg.find(lrf_test::shared_dir() + "/models"), std::string::npos) << msg;
  ::unsetenv("LRF_MODELS");
}

// Stage I in miniature: Adam on the encoder with the decoder frozen.
TEST(TinyAutoencoder, AdamOnEncoderReducesLossAndLeavesFrozenDecoderUntouched) {
  torch::manual_seed(0);
  auto ae = lrf::load_autoencoder(taef2_dir());
  cv::Mat image = lrf::center_crop_to_multiple(lrf::read_image_rgb(first_fern_image()), 8);
  at::Tensor x = lrf::image_to_batch(image).narrow(2, 100, 64).narrow(3, 200, 64).contiguous();
  // Make the task non-trivial: the target is a brightened image, which the frozen decoder can only
  // approach through the encoder's latents.
  at::Tensor target = (x * 1.2).clamp(0, 1);
  ae->set_decoder_trainable(false);
  std::vector<at::Tensor> decoder_before;
  for (const auto& p : ae->decoder_parameters()) decoder_before.push_back(p.detach().clone());
  std::vector<at::Tensor> encoder_before;
  for (const auto& p : ae->encoder_parameters()) encoder_before.push_back(p.detach().clone());
  torch::optim::Adam adam(ae->encoder_parameters(), torch::optim::AdamOptions(1e-4));
  auto loss_now = [&] { return torch::l1_loss(ae->decode(ae->encode(x)), target); };
  double first = 0, last = 0;
  for (int step = 0; step < 6; ++step) {
    adam.zero_grad();
    at::Tensor loss = loss_now();
    if (step == 0) first = loss.item<double>();
    loss.backward();
    adam.step();
  }
  {
    torch::NoGradGuard no_grad;
    last = loss_now().item<double>();
  }
  std::printf("encoder fine-tuning: L1 %.5f -> %.5f\n", first, last);
  EXPECT_LT(last, first * 0.98);
  auto dec = ae->decoder_parameters();
  for (std::size_t i = 0; i < dec.size(); ++i) {
    EXPECT_FALSE(dec[i].grad().defined());
    EXPECT_TRUE(torch::equal(dec[i], decoder_before[i])) << "frozen decoder parameter " << i << " changed";
  }
  auto enc = ae->encoder_parameters();
  int changed = 0;
  for (std::size_t i = 0; i < enc.size(); ++i) changed += !torch::equal(enc[i], encoder_before[i]);
  EXPECT_EQ(changed, static_cast<int>(enc.size()));
}

// Stage III in miniature on the KL-VAE: Adam on the decoder with the encoder frozen.
TEST(KLAutoencoder, AdamOnDecoderReducesLossAndLeavesFrozenEncoderUntouched) {
  torch::manual_seed(0);
  lrf::KLConfig cfg;
  cfg.ch = 32;
  lrf::KLAutoencoder ae(cfg);
  at::Tensor x = torch::rand({1, 3, 32, 32});
  at::Tensor z;
  {
    torch::NoGradGuard no_grad;
    z = ae.encode(x);
  }
  ae.set_encoder_trainable(false);
  auto encoder_before = ae.encoder_state();
  torch::optim::Adam adam(ae.decoder_parameters(), torch::optim::AdamOptions(1e-3));
  double first = 0, last = 0;
  for (int step = 0; step < 5; ++step) {
    adam.zero_grad();
    at::Tensor loss = torch::l1_loss(ae.decode(ae.encode(x)), x);
    if (step == 0) first = loss.item<double>();
    loss.backward();
    adam.step();
  }
  {
    torch::NoGradGuard no_grad;
    last = torch::l1_loss(ae.decode(ae.encode(x)), x).item<double>();
  }
  EXPECT_LT(last, first * 0.95);
  auto after = ae.encoder_state();
  for (const auto& item : encoder_before) EXPECT_TRUE(torch::equal(item.value(), after[item.key()])) << item.key();
}
