// VAElight, the 4-channel autoencoder in Stable Diffusion's latent space: the real checkpoints against an
// independent PyTorch reading of them, the round trip on real photos, strict loading, and the pieces the
// rest of lrf relies on (the transposed layer against plain loops, the local reach of the decoder).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "lrf/autoencoder/autoencoder.h"
#include "lrf/autoencoder/image_tensor.h"
#include "lrf/autoencoder/transposed_up2.h"
#include "lrf/autoencoder/vaelight.h"
#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/core/safetensors.h"
#include "lrf/eval/metrics.h"
#include "reference_helper.h"
#include "test_helpers.h"

namespace fs = std::filesystem;

namespace {

std::string vaelight_dir() { return lrf_test::shared_dir() + "/models/vaelight"; }

std::vector<std::string> fern_images() {
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(lrf_test::shared_dir() + "/scenes/llff-fern/images_8"))
    if (e.path().extension() == ".png") files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

at::Tensor fern_view(const std::string& path) {
  return lrf::image_to_batch(lrf::center_crop_to_multiple(lrf::read_image_rgb(path), 8));
}

double max_abs(const at::Tensor& a, const at::Tensor& b) { return (a - b).abs().max().item<double>(); }

using lrf::test::error_of;

// The transposed convolution written out: out[o, 2y+i, 2x+j] = b[o] + sum_c x[c, y, x] w[c, o, i, j].
at::Tensor transposed_loops(const at::Tensor& x, const at::Tensor& w, const at::Tensor& b) {
  const int64_t n = x.size(0), in = x.size(1), h = x.size(2), wd = x.size(3), out = w.size(1);
  at::Tensor y = torch::zeros({n, out, 2 * h, 2 * wd}, torch::kDouble);
  auto X = x.accessor<double, 4>();
  auto W = w.accessor<double, 4>();
  auto B = b.accessor<double, 1>();
  auto Y = y.accessor<double, 4>();
  for (int64_t s = 0; s < n; ++s)
    for (int64_t o = 0; o < out; ++o)
      for (int64_t r = 0; r < h; ++r)
        for (int64_t c = 0; c < wd; ++c)
          for (int i = 0; i < 2; ++i)
            for (int j = 0; j < 2; ++j) {
              double v = B[o];
              for (int64_t k = 0; k < in; ++k) v += X[s][k][r][c] * W[k][o][i][j];
              Y[s][o][2 * r + i][2 * c + j] = v;
            }
  return y;
}

}  // namespace

TEST(VaeLight, MatchesPyTorchOnRealImage) {
  torch::NoGradGuard no_grad;
  auto ae = lrf::load_autoencoder("vaelight");
  ASSERT_EQ(ae->kind(), "vaelight");
  ASSERT_EQ(ae->latent_channels(), 4);
  ae->set_precision(lrf::Precision::fp32);
  at::Tensor x = fern_view(fern_images().front());
  ASSERT_EQ(x.sizes(), (std::vector<int64_t>{1, 3, 376, 504}));
  const std::string input = lrf_test::fixture_input("vaelight", x);
  fs::path dir = lrf_test::cached_fixture("vaelight", "vaelight --weights " + vaelight_dir() + " --input " + input);
  ASSERT_FALSE(dir.empty());
  auto ref = lrf::read_safetensors((dir / "ref.safetensors").string());
  at::Tensor z = ae->encode(x);
  ASSERT_EQ(z.sizes(), (std::vector<int64_t>{1, 4, 47, 63}));
  at::Tensor y = ae->decode(z);
  const double dz = max_abs(z, ref["latent"]), dy = max_abs(y, ref["decoded"]);
  const double latent_range = ref["latent"].abs().max().item<double>();
  std::printf("VAElight vs PyTorch: latent max abs diff %.3g (largest |latent| %.3g), decoded %.3g\n", dz,
              latent_range, dy);
  // Both sides sum the same float32 products in other orders (oneDNN here, PyTorch's own kernels there):
  // about 1e-6 of the largest value per layer over 11 layers. 1e-4 of the latents' range (SD's raw scale,
  // tens) and 1e-4 of the image's still catch any wrong layer, key, activation or upsampling (>1e-2).
  EXPECT_LE(dz, 1e-4 * latent_range);
  EXPECT_LE(dy, 1e-4);
  // SD's raw latent scale: a standard deviation of several units, not the 0.18215-scaled one.
  EXPECT_GT(z.std().item<double>(), 2.0);
  EXPECT_GT(y.std().item<double>(), 0.05);
}

TEST(VaeLight, RoundTripsFernAsItsReadmeSays) {
  // The weights' README: 21.22 dB over fern's 20 views at images_8, outputs rounded to 8 bits. Float
  // outputs score a few hundredths above the rounded ones; a wrong layer costs whole decibels.
  torch::NoGradGuard no_grad;
  auto ae = lrf::load_autoencoder("vaelight");
  double sum = 0;
  const auto files = fern_images();
  for (const auto& f : files) {
    at::Tensor x = fern_view(f);
    at::Tensor y = (ae->decode(ae->encode(x)) * 255).round() / 255;
    sum += lrf::psnr(y.squeeze(0), x.squeeze(0));
  }
  const double mean = sum / static_cast<double>(files.size());
  std::printf("VAElight round trip over %zu fern views: %.3f dB (%s)\n", files.size(), mean,
              lrf::precision_name(ae->precision()).c_str());
  // bf16 (where the CPU has it natively) rounds each layer's inputs to 8 bits of mantissa: within 0.1 dB.
  EXPECT_NEAR(mean, 21.22, ae->precision() == lrf::Precision::bf16 ? 0.1 : 0.02);
}

TEST(VaeLight, TransposedLayerIsThePlainLoopsValuesAndGradients) {
  torch::manual_seed(1);
  const auto f64 = torch::TensorOptions().dtype(torch::kDouble);
  at::Tensor x = torch::randn({2, 3, 4, 5}, f64).requires_grad_(true);
  at::Tensor w = torch::randn({3, 5, 2, 2}, f64).requires_grad_(true);
  at::Tensor b = torch::randn({5}, f64).requires_grad_(true);
  at::Tensor y = lrf::transposed_conv2x2(x, w, b);
  at::Tensor want = transposed_loops(x.detach(), w.detach(), b.detach());
  ASSERT_EQ(y.sizes(), want.sizes());
  EXPECT_LT(max_abs(y.detach(), want), 1e-12);
  // Gradients of a fixed random projection of the output, against central differences of the loops
  // (the loops are linear, so central differences are exact up to rounding: 1e-6 leaves ample room).
  at::Tensor proj = torch::randn(want.sizes(), f64);
  (y * proj).sum().backward();
  const double h = 1e-3;
  for (auto* t : {&x, &w, &b}) {
    at::Tensor flat = t->detach().clone().reshape({-1});
    at::Tensor grad = t->grad().reshape({-1});
    for (int64_t i = 0; i < flat.numel(); i += 7) {
      auto eval = [&](double delta) {
        at::Tensor v = flat.clone();
        v[i] += delta;
        at::Tensor shaped = v.reshape(t->sizes());
        at::Tensor xs = t == &x ? shaped : x.detach(), ws = t == &w ? shaped : w.detach(), bs = t == &b ? shaped : b.detach();
        return (transposed_loops(xs, ws, bs) * proj).sum().item<double>();
      };
      const double numeric = (eval(h) - eval(-h)) / (2 * h);
      EXPECT_NEAR(grad[i].item<double>(), numeric, 1e-6) << "element " << i;
    }
  }
}

TEST(VaeLight, WindowsDecodeExactlyWithinTheLocalReach) {
  // What refinement's crops rely on: a pixel whose latent cell lies decode_local_reach() cells inside a
  // window decodes from the window alone exactly as from the whole latent.
  torch::NoGradGuard no_grad;
  torch::manual_seed(2);
  lrf::VaeLightAutoencoder ae;
  ae.set_channels_last(true);
  const int reach = ae.decode_local_reach();
  at::Tensor z = torch::randn({1, 4, 20, 24}) * 3;
  at::Tensor whole = ae.decode_unclamped(z);
  const lrf::CellRect window{3, 2, 14, 16};  // not touching the image's edges
  at::Tensor features = ae.decode_global(z).narrow(2, window.y, window.h).narrow(3, window.x, window.w);
  const lrf::CellRect inner{reach, reach, window.h - 2 * reach, window.w - 2 * reach};
  at::Tensor part = ae.decode_local_window(features, inner, {});
  at::Tensor want = whole.narrow(2, 8 * (window.y + reach), 8 * inner.h).narrow(3, 8 * (window.x + reach), 8 * inner.w);
  EXPECT_LT(max_abs(part, want), 1e-5);
  // One cell less would not do: the reach is what the layers need, not a loose bound.
  const lrf::CellRect closer{reach - 1, reach - 1, window.h - 2 * reach + 2, window.w - 2 * reach + 2};
  at::Tensor near_edge = ae.decode_local_window(features, closer, {});
  at::Tensor want_near = whole.narrow(2, 8 * (window.y + reach - 1), 8 * closer.h)
                             .narrow(3, 8 * (window.x + reach - 1), 8 * closer.w);
  EXPECT_GT(max_abs(near_edge, want_near), 1e-3);
}

TEST(VaeLight, DecoderLayersReportTheirResolution) {
  lrf::VaeLightAutoencoder ae;
  EXPECT_EQ(ae.decoder_parameter_scale("cv2.weight"), 1);
  EXPECT_EQ(ae.decoder_parameter_scale("cv3.weight"), 2);
  EXPECT_EQ(ae.decoder_parameter_scale("cv8.bias"), 4);
  EXPECT_EQ(ae.decoder_parameter_scale("cv11.weight"), 8);
  EXPECT_EQ(ae.decoder_parameter_scale("c4v8.weight"), 4);
  EXPECT_EQ(ae.decoder_parameter_scale("c3v5.weight"), 2);
  EXPECT_EQ(ae.decoder_parameter_scale("c2v4.weight"), 1);
  // Stage III's low-resolution option trains the coarse layers only.
  const size_t all = ae.decoder_parameters().size(), coarse = ae.decoder_parameters(1).size();
  EXPECT_EQ(all, 2u * (11 + 8 + 5 + 4));
  EXPECT_EQ(coarse, 2u * (2 + 2 + 2 + 4));
}

TEST(VaeLight, HalvesSaveAndReloadThroughTheFactory) {
  torch::NoGradGuard no_grad;
  auto ae = lrf::load_autoencoder("vaelight");
  auto dir = lrf_test::fresh_dir("vaelight_halves");
  const std::string enc = (dir / "enc.safetensors").string(), dec = (dir / "dec.safetensors").string();
  ae->save_encoder(enc);
  ae->save_decoder(dec);
  auto again = lrf::load_autoencoder("vaelight", enc, dec);
  EXPECT_EQ(again->description().find("encoder " + enc) != std::string::npos, true);
  at::Tensor x = torch::rand({1, 3, 32, 40});
  EXPECT_TRUE(torch::equal(again->decode(again->encode(x)), ae->decode(ae->encode(x))));
  // A folder of the two saved halves is a vaelight autoencoder too.
  fs::rename(enc, dir / "vaelight_encoder.safetensors");
  fs::rename(dec, dir / "vaelight_decoder.safetensors");
  EXPECT_EQ(lrf::load_autoencoder(dir.string())->kind(), "vaelight");
  fs::remove_all(dir);
}

TEST(VaeLight, ForeignTruncatedAndSwappedCheckpointsAreRefusedNamingTheFile) {
  auto ae = lrf::load_autoencoder("vaelight");
  const std::string enc = vaelight_dir() + "/vaelight_encoder_15012.pt", dec = vaelight_dir() + "/vaelight_decoder_12870.pt";
  // The decoder's checkpoint offered as the encoder: the names overlap (cv1..cv6), the shapes and the rest do not.
  std::string msg = error_of([&] { ae->load_encoder(dec); });
  EXPECT_NE(msg.find("vaelight_decoder_12870.pt (vaelight encoder)"), std::string::npos) << msg;
  EXPECT_NE(msg.find("missing"), std::string::npos) << msg;
  EXPECT_NE(msg.find("cv14.weight"), std::string::npos) << msg;
  // TAEF2's decoder offered as VAElight's.
  msg = error_of([&] { ae->load_decoder(lrf_test::shared_dir() + "/models/taef2/taef2_decoder.pth"); });
  EXPECT_NE(msg.find("taef2_decoder.pth (vaelight decoder)"), std::string::npos) << msg;
  EXPECT_NE(msg.find("unexpected"), std::string::npos) << msg;
  // A truncated copy of the encoder's checkpoint.
  auto dir = lrf_test::fresh_dir("vaelight_bad");
  {
    std::ifstream in(enc, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(dir / "cut.pt", std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));
  }
  msg = error_of([&] { ae->load_encoder((dir / "cut.pt").string()); });
  EXPECT_NE(msg.find("cut.pt"), std::string::npos) << msg;
  // A folder whose encoder is VAElight's and decoder TAEF2's is refused as a whole, naming both files.
  fs::copy_file(enc, dir / "vaelight_encoder.pt");
  fs::copy_file(lrf_test::shared_dir() + "/models/taef2/taef2_decoder.pth", dir / "taef2_decoder.pth");
  fs::remove(dir / "cut.pt");
  msg = error_of([&] { lrf::load_autoencoder(dir.string()); });
  EXPECT_NE(msg.find("taef2_decoder.pth"), std::string::npos) << msg;
  EXPECT_NE(msg.find("vaelight"), std::string::npos) << msg;
  fs::remove_all(dir);
}
