// Decoder-aware refinement: the split decoder decodes a window exactly as the whole latent does, the
// decoded loss sees the right pixels, and refining a latent field through the real TAEF2 decoder lowers
// the image loss on views it never saw; resume and bad input.
#include <cstdio>
#include <filesystem>
#include <random>

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "lrf/autoencoder/autoencoder.h"
#include "lrf/autoencoder/image_tensor.h"
#include "lrf/autoencoder/kl_vae.h"
#include "lrf/autoencoder/tiny_ae.h"
#include "lrf/core/cpu_features.h"
#include "lrf/core/run_info.h"
#include "lrf/latent/latent_field.h"
#include "lrf/latent/latent_run.h"
#include "lrf/latent/latent_train_run.h"
#include "lrf/refine/decoded_loss.h"
#include "lrf/refine/refine.h"
#include "lrf/splat/ply_io.h"
#include "lrf/splat/render_field.h"
#include "lrf/splat/train/loss.h"
#include "lrf/splat/train/spatial_order.h"
#include "test_helpers.h"

namespace fs = std::filesystem;

namespace {

std::string taef2() { return lrf::test::shared_dir() + "/models/taef2"; }

// Decodes the window [y0, y1) x [x0, x1) of latent z with `margin` cells of context and returns the
// pixels of the window, next to the same pixels of the whole decode.
std::pair<at::Tensor, at::Tensor> window_and_whole(lrf::Autoencoder& ae, const at::Tensor& z, int64_t y, int64_t x,
                                                   int64_t n, int margin) {
  torch::NoGradGuard no_grad;
  const at::Tensor whole = ae.decode_unclamped(z);
  const at::Tensor f = ae.decode_global(z);
  const int64_t y0 = std::max<int64_t>(0, y - margin), x0 = std::max<int64_t>(0, x - margin);
  const int64_t y1 = std::min(z.size(2), y + n + margin), x1 = std::min(z.size(3), x + n + margin);
  const at::Tensor part = ae.decode_local(f.narrow(2, y0, y1 - y0).narrow(3, x0, x1 - x0));
  return {part.narrow(2, 8 * (y - y0), 8 * n).narrow(3, 8 * (x - x0), 8 * n),
          whole.narrow(2, 8 * y, 8 * n).narrow(3, 8 * x, 8 * n)};
}

// TAEF2's decoder: group norms in its first three blocks, then 3x3 convolutions whose reach is
// 4.5 + 2.25 + ... = 8.125 latent cells (see tiny_ae.cpp). With that context a window decodes to exactly
// the whole decode's pixels (up to float rounding: oneDNN may pick another convolution algorithm for
// another size, ~1e-6); with none, the window's edge is off by far more than a grey level.
TEST(DecoderSplit, Taef2WindowWithReachEqualsWholeDecode) {
  auto ae = lrf::load_autoencoder(taef2());
  EXPECT_EQ(ae->decode_local_reach(), 9);
  torch::manual_seed(3);
  at::Tensor image = torch::rand({1, 3, 8, 12}).repeat_interleave(16, 2).repeat_interleave(16, 3);  // 128x192
  at::Tensor z;
  {
    torch::NoGradGuard no_grad;
    z = ae->encode(image);
  }
  {
    auto [part, whole] = window_and_whole(*ae, z, 4, 6, 6, ae->decode_local_reach());
    EXPECT_LT((part - whole).abs().max().item<double>(), 2e-5);
  }
  {
    auto [part, whole] = window_and_whole(*ae, z, 4, 6, 6, 0);
    EXPECT_GT((part - whole).abs().max().item<double>(), 0.02);
  }
  // decode() is the clamped whole decode.
  torch::NoGradGuard no_grad;
  EXPECT_TRUE(torch::allclose(ae->decode(z), ae->decode_unclamped(z).clamp(0, 1)));
}

// Without group norms (TAESD's layout) the whole decoder is local: 18.125 cells -> 19.
TEST(DecoderSplit, TinyWithoutPoolIsLocalThroughoutAndKlIsNotLocal) {
  torch::manual_seed(0);
  lrf::TinyAutoencoder tiny(4, false);
  EXPECT_EQ(tiny.decode_local_reach(), 19);
  at::Tensor z = torch::randn({1, 4, 44, 46});
  auto [part, whole] = window_and_whole(tiny, z, 20, 21, 3, 19);
  EXPECT_LT((part - whole).abs().max().item<double>(), 1e-5);
  lrf::KLConfig cfg;
  cfg.ch = 32;
  lrf::KLAutoencoder kl(cfg);
  EXPECT_EQ(kl.decode_local_reach(), -1);
}

namespace {

struct WindowCase {
  int64_t y, x, h, w;
};

struct WindowDifference {
  double value_max;  // largest difference of a pixel, over the largest pixel
  double grad_max;   // largest difference of a latent's gradient, over the largest gradient
  double grad_rms;   // rms difference of the gradients, over their rms
};

// One window decoded by decode_local_window and cut out of the whole decode, with the gradients that a
// random weighting of its pixels sends back into the latent through each.
WindowDifference window_against_whole(lrf::TinyAutoencoder& ae, const at::Tensor& z, const WindowCase& c) {
  const int reach = ae.decode_local_reach();
  const int64_t H = z.size(2), W = z.size(3);
  const int64_t y0 = std::max<int64_t>(0, c.y - reach), x0 = std::max<int64_t>(0, c.x - reach);
  const int64_t y1 = std::min<int64_t>(H, c.y + c.h + reach), x1 = std::min<int64_t>(W, c.x + c.w + reach);
  const at::Tensor weights = torch::randn({1, 3, 8 * c.h, 8 * c.w});
  const at::Tensor zw = z.clone().requires_grad_(true);
  const at::Tensor part = ae.decode_local_window(ae.decode_global(zw).narrow(2, y0, y1 - y0).narrow(3, x0, x1 - x0),
                                                 {c.y - y0, c.x - x0, c.h, c.w}, {y0 == 0, x0 == 0, y1 == H, x1 == W});
  EXPECT_EQ(part.sizes(), (std::vector<int64_t>{1, 3, 8 * c.h, 8 * c.w}));
  (part * weights).sum().backward();
  const at::Tensor zd = z.clone().requires_grad_(true);
  const at::Tensor whole = ae.decode_unclamped(zd).narrow(2, 8 * c.y, 8 * c.h).narrow(3, 8 * c.x, 8 * c.w);
  (whole * weights).sum().backward();
  const at::Tensor dg = zw.grad() - zd.grad();
  EXPECT_GT(zd.grad().abs().max().item<double>(), 0);
  return {(part - whole).abs().max().item<double>() / whole.abs().max().item<double>(),
          dg.abs().max().item<double>() / zd.grad().abs().max().item<double>(),
          (dg.pow(2).mean().sqrt() / zd.grad().pow(2).mean().sqrt()).item<double>()};
}

const std::vector<WindowCase> kWindows{{10, 11, 3, 4}, {0, 0, 4, 7}, {18, 21, 6, 7}, {0, 0, 24, 28}, {11, 0, 3, 28}};

std::string describe(const WindowCase& c) {
  return "window at " + std::to_string(c.y) + "," + std::to_string(c.x) + " of " + std::to_string(c.h) + "x" +
         std::to_string(c.w);
}

// Every window of kWindows against the whole decode of `z`, within these bounds.
void expect_windows_within(lrf::TinyAutoencoder& ae, const at::Tensor& z, double value_max, double grad_max,
                           double grad_rms) {
  for (const WindowCase& c : kWindows) {
    SCOPED_TRACE(describe(c));
    const WindowDifference d = window_against_whole(ae, z, c);
    EXPECT_LT(d.value_max, value_max);
    EXPECT_LT(d.grad_max, grad_max);
    EXPECT_LT(d.grad_rms, grad_rms);
  }
}

}  // namespace

// decode_local_window computes each layer only where the layers after it need it (tiny_window_decode.cpp):
// its pixels are the whole decode's, and so is the gradient it sends back into the latent, for windows
// inside the image, against its corners and edges, and for the whole image. float32 with random weights
// of TAEF2's layout, on direct convolutions (the cuts are what is tested): oneDNN may sum another size's
// convolution in another order, which moves a value by float rounding (~1e-6 of values of order 1 after 20
// layers); a misplaced cut moves it by far more.
TEST(DecoderSplit, WindowDecodeEqualsTheWholeDecodeAndItsGradient) {
  lrf::test::ScopedEnv direct("LRF_WINOGRAD", "0");
  torch::manual_seed(5);
  lrf::TinyAutoencoder ae(8, true);
  const at::Tensor z = torch::randn({1, 8, 24, 28});
  expect_windows_within(ae, z, 2e-5, 2e-5, 2e-5);
  // A window with less context than the decoder reaches on a side inside the image is refused.
  const at::Tensor f = ae.decode_global(z);
  EXPECT_NE(lrf::test::error_of([&] {
              ae.decode_local_window(f.narrow(2, 2, 20).narrow(3, 2, 20), {3, 9, 4, 4}, {false, false, false, false});
            }).find("context"),
            std::string::npos);
  EXPECT_NE(lrf::test::error_of([&] { ae.decode_local_window(f, {22, 0, 4, 4}, {true, true, true, true}); })
                .find("does not lie inside"),
            std::string::npos);
}

// On the float32 Winograd path (where the CPU has AVX2) a window starts at another place in the 4x4 tile
// grid than the whole image does, so each layer rounds its values differently (~1e-6 of them, as
// test_winograd_f32 measures), and through 20 layers of random weights and their ReLU masks the
// latent's gradient moves by 4-6e-4 of its rms (measured on an AVX2 EPYC; pixels by < 1e-5). A cut one
// cell off moves values by > 2e-2 (the first test), a hundred times the bound here.
TEST(DecoderSplit, WindowDecodeOnTheWinogradPathMatchesWithinItsRounding) {
  if (!lrf::winograd_f32_enabled()) GTEST_SKIP() << "this CPU has no float32 Winograd path";
  torch::manual_seed(5);
  lrf::TinyAutoencoder ae(8, true);
  expect_windows_within(ae, torch::randn({1, 8, 24, 28}), 1e-4, 5e-3, 2e-3);
}

TEST(DecodedLoss, WindowsStayInsideAndTheLossComparesTheMatchingPixels) {
  std::mt19937_64 rng(1);
  for (int k = 0; k < 200; ++k) {
    auto w = lrf::plan_window(47, 63, 16, 9, rng);
    ASSERT_GE(w.y, 0);
    ASSERT_LE(w.y + w.h, 47);
    ASSERT_LE(w.x + w.w, 63);
    ASSERT_EQ(w.y0, std::max<int64_t>(0, w.y - 9));
    ASSERT_EQ(w.x1, std::min<int64_t>(63, w.x + 16 + 9));
  }
  auto whole = lrf::plan_window(47, 63, 0, 9, rng);
  EXPECT_EQ(whole.h, 47);
  EXPECT_EQ(whole.w, 63);

  // A latent that decodes to an image, and that image as the target: zero L1 in the window, whatever
  // window; a target shifted by one latent cell is not.
  auto ae = lrf::load_autoencoder(taef2());
  lrf::LatentRange range;
  range.min.assign(32, -4.0f);
  range.max.assign(32, 4.0f);
  torch::manual_seed(2);
  at::Tensor zn = torch::rand({32, 10, 14}) * 0.4 + 0.3;
  at::Tensor image;
  {
    torch::NoGradGuard no_grad;
    image = ae->decode_unclamped(range.denormalize(zn).unsqueeze(0))[0];
  }
  for (int k = 0; k < 3; ++k) {
    auto w = lrf::plan_window(10, 14, 4, ae->decode_local_reach(), rng);
    auto d = lrf::decoded_loss(*ae, range, zn, image, w, 0.0);
    EXPECT_LT(d.loss.item<double>(), 1e-5);
    EXPECT_EQ(d.decoded.sizes(), (std::vector<int64_t>{3, 32, 32}));
  }
  auto w = lrf::plan_window(10, 14, 4, ae->decode_local_reach(), rng);
  auto shifted = lrf::decoded_loss(*ae, range, zn, image.roll(8, 2), w, 0.0);
  EXPECT_GT(shifted.loss.item<double>(), 1e-3);
  // The gradient reaches the latent.
  at::Tensor leaf = zn.clone().requires_grad_(true);
  lrf::decoded_loss(*ae, range, leaf, image.roll(8, 2), w, 0.2).loss.backward();
  EXPECT_GT(leaf.grad().abs().sum().item<double>(), 0);
}

// A latent rendered by a camera shifted (dx, dy) pixels shows the image moved by (dx, dy): its pixel (u, v)
// is compared with the image's (u - dx, v - dy). A target made that way matches exactly in every window,
// also those at the top left whose first rows and columns have no counterpart; unshifted, it does not.
TEST(DecodedLoss, AShiftedViewIsComparedWithTheImageMovedByTheShift) {
  auto ae = lrf::load_autoencoder(taef2());
  lrf::LatentRange range;
  range.min.assign(32, -4.0f);
  range.max.assign(32, 4.0f);
  torch::manual_seed(3);
  const at::Tensor zn = torch::rand({32, 10, 14}) * 0.4 + 0.3;
  at::Tensor decoded;
  {
    torch::NoGradGuard no_grad;
    decoded = ae->decode_unclamped(range.denormalize(zn).unsqueeze(0))[0];
  }
  const int dx = 3, dy = 5;
  at::Tensor image = torch::rand_like(decoded);  // rows and columns the shifted view never shows stay noise
  image.narrow(1, 0, 80 - dy).narrow(2, 0, 112 - dx).copy_(decoded.narrow(1, dy, 80 - dy).narrow(2, dx, 112 - dx));
  std::mt19937_64 rng(4);
  std::vector<lrf::DecodeWindow> windows = {lrf::plan_window(10, 14, 0, ae->decode_local_reach(), rng)};
  lrf::DecodeWindow corner = lrf::plan_window(10, 14, 4, ae->decode_local_reach(), rng);
  corner.y = 0, corner.x = 0, corner.y0 = 0, corner.x0 = 0;
  corner.y1 = std::min<int64_t>(10, 4 + ae->decode_local_reach());
  corner.x1 = std::min<int64_t>(14, 4 + ae->decode_local_reach());
  windows.push_back(corner);
  for (int k = 0; k < 3; ++k) windows.push_back(lrf::plan_window(10, 14, 4, ae->decode_local_reach(), rng));
  for (const auto& w : windows) {
    const auto d = lrf::decoded_loss(*ae, range, zn, image, w, 0.2, dx, dy);
    EXPECT_LT(d.loss.item<double>(), 1e-5) << w.y << "," << w.x;
    const int64_t top = w.y == 0 ? dy : 0, left = w.x == 0 ? dx : 0;
    EXPECT_EQ(d.decoded.sizes(), (std::vector<int64_t>{3, 8 * w.h - top, 8 * w.w - left}));
    EXPECT_GT(lrf::decoded_loss(*ae, range, zn, image, w, 0.2).loss.item<double>(), 1e-2);
  }
  EXPECT_NE(lrf::test::error_of([&] { lrf::decoded_loss(*ae, range, zn, image, windows[0], 0.2, -1, 0); })
                .find("shift"),
            std::string::npos);
}

// The default length is a number of passes per training view (fern's 17 views: the 1000 steps it was
// chosen with), taken from the source run's record; an explicit --steps stays as given.
TEST(RefineSteps, DefaultLengthFollowsTheTrainingViews) {
  lrf::RefineOptions o;
  ASSERT_EQ(o.steps, 0);
  EXPECT_EQ(lrf::refine_steps(o, 17), 1000);
  EXPECT_EQ(lrf::refine_steps(o, 35), 2100);
  EXPECT_EQ(lrf::refine_steps(o, 58), 3500);
  EXPECT_EQ(lrf::refine_steps(o, 1), 100);
  o.steps = 250;
  EXPECT_EQ(lrf::refine_steps(o, 35), 250);
  EXPECT_NE(lrf::refine_description(o).find("250 steps"), std::string::npos);
  o.steps = 0;
  EXPECT_NE(lrf::refine_description(o).find("60 steps per training view"), std::string::npos);

  lrf::test::TempDir dir("refine_steps");
  o.run = dir / "field";
  fs::create_directories(o.run);
  lrf::write_json_file(dir / "field/config.json", {{"train_views", 29}});
  EXPECT_EQ(lrf::with_refine_steps(o).steps, 1700);
  lrf::write_json_file(dir / "field/config.json", {{"space", "latent"}});
  EXPECT_NE(lrf::test::error_of([&] { lrf::with_refine_steps(o); }).find("train_views"), std::string::npos);
  o.steps = 300;
  EXPECT_EQ(lrf::with_refine_steps(o).steps, 300);
}

// Mean image L1 of the decoded held-out views of a latent run (decoded by `decoder`, "" = the run's).
double held_out_l1(const std::string& run_dir) {
  lrf::LatentRun run = lrf::open_latent_run(run_dir);
  auto ae = lrf::load_autoencoder(run.autoencoder, run.encoder, run.decoder);
  double sum = 0;
  for (int i : run.scene.test_indices) {
    at::Tensor decoded = lrf::decode_normalised(*ae, run.range, lrf::render_latent(run, i));
    at::Tensor truth = lrf::image_to_batch(run.scene.load_image(i))[0];
    sum += (decoded - truth).abs().mean().item<double>();
  }
  return sum / double(run.scene.test_indices.size());
}

class RefineRun : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new lrf::test::TempDir("refine");
    lrf::LatentTrainOptions o;
    o.scene = lrf::test::synthetic_scene({16, "128x96", 7, 1500});
    o.out = *dir_ / "field";
    o.autoencoder = taef2();
    o.iters = 300;
    // Inria's rates: the refinement bounds below were measured on this field. With the short-run rates the
    // field starts nearer the held-out views (mean L1 0.1008 against 0.1098) and refining ends lower (0.0959
    // against 0.0966), a relative gain below the 8% the bounds ask.
    o.short_run_rates = false;
    o.cache_dir = *dir_ / "cache";
    lrf::train_latent_field(o);
  }
  static void TearDownTestSuite() { delete dir_; }
  static lrf::RefineOptions options(const std::string& out, int64_t steps) {
    lrf::RefineOptions r;
    r.run = *dir_ / "field";
    r.out = *dir_ / out;
    r.steps = steps;
    r.checkpoint_every = 20;
    // Each test turns on what it exercises: by default the field alone moves, through the stock decoder, at
    // Stage II's rates, constant (the bounds below were measured at them).
    r.lr_scale = 1;
    r.decoder_lr = 0;
    r.densify_until = 0;
    r.jitter = 0;
    r.lr_final = 1;
    r.lr_decay_start = 0;
    return r;
  }
  // Runs `o` to `first` steps (checkpointing there), then resumes it to o.steps.
  static void refine_interrupted_at(lrf::RefineOptions o, int64_t first) {
    const int64_t steps = o.steps;
    o.steps = first;
    o.checkpoint_every = first;
    lrf::refine_latent_field(o);
    o.steps = steps;
    o.resume = true;
    lrf::refine_latent_field(o);
  }
  // The two runs' fields are the same bit for bit.
  static void expect_same_field(const std::string& a_out, const std::string& b_out) {
    auto a = lrf::splat::read_ply(*dir_ / (a_out + "/point_cloud.ply"), 32);
    auto b = lrf::splat::read_ply(*dir_ / (b_out + "/point_cloud.ply"), 32);
    ASSERT_EQ(a.size(), b.size());
    EXPECT_TRUE(torch::equal(a.means, b.means));
    EXPECT_TRUE(torch::equal(a.sh, b.sh));
  }
  static lrf::test::TempDir* dir_;
};
lrf::test::TempDir* RefineRun::dir_ = nullptr;

// The point of refinement: on the synthetic scene's held-out views (never used by either stage), the
// decoded images get closer to the truth. Measured: mean L1 0.1109 -> 0.0972 (-12 %) after 60 steps. The
// test asks for -8 %: with the targets shifted by two latent cells the same run gets -6.7 % (a smooth scene
// forgives small shifts; DecodedLoss above catches any shift exactly), with no gradient 0 %.
TEST_F(RefineRun, RefinementLowersTheImageLossOnHeldOutViews) {
  const double before = held_out_l1(*dir_ / "field");
  auto o = options("refined", 60);
  o.score_every = 25;
  auto r = lrf::refine_latent_field(o);
  EXPECT_EQ(r.steps, 60);
  const double after = held_out_l1(*dir_ / "refined");
  std::printf("held-out mean L1 %.4f -> %.4f\n", before, after);
  EXPECT_LT(after, 0.92 * before) << "before " << before << " after " << after;
  // A latent run like any other: eval works and reports the decoder it was refined through.
  auto m = lrf::evaluate_latent_run(*dir_ / "refined", {});
  EXPECT_EQ(m["decoder"], "stock");
  // The quality curve: rows at steps 25, 50 and the last, the wall time growing from the source run's, and
  // the last row scoring the written field as eval does.
  const std::string curve = *dir_ / "refined/curve.csv";
  const std::vector<double> steps = lrf::test::logged_column(curve, "step");
  ASSERT_EQ(steps, (std::vector<double>{25, 50, 60}));
  const std::vector<double> seconds = lrf::test::logged_column(curve, "seconds");
  const std::vector<double> refine_seconds = lrf::test::logged_column(curve, "refine_seconds");
  const auto source = lrf::read_json_file(*dir_ / "field/config.json")["result"];
  EXPECT_NEAR(seconds[0] - refine_seconds[0],
              source["seconds"].get<double>() + source["encode_seconds"].get<double>(), 1e-3);
  EXPECT_LT(refine_seconds[0], refine_seconds[1]);
  EXPECT_NEAR(lrf::test::logged_column(curve, "psnr").back(), m["psnr"].get<double>(), 1e-3);
  const auto config = lrf::read_json_file(*dir_ / "refined/config.json");
  EXPECT_EQ(config["refine"]["refined_from"], fs::weakly_canonical(*dir_ / "field").string());
  EXPECT_GT(config["result"]["refine_seconds"].get<double>(), 0);
}

// The camera a jittered step renders with moves the latent's content the way DecodedLoss above assumes:
// shifted by 8 and 16 image pixels (one and two latent cells), the render is the unshifted one moved by one
// column and two rows. Compared on the Gaussians whose centres both frames see: one near a frame's edge is
// culled, or its projection clamped as in 3DGS, in one frame and not the other, and a large one reaches
// far inside (on this field up to 0.01 three cells in, depending on how the field trained).
TEST_F(RefineRun, ShiftedLatentCameraMovesTheContentByTheShift) {
  lrf::LatentRun run = lrf::open_latent_run(*dir_ / "field");
  const int i = run.scene.train_indices.front();
  const lrf::Camera cam = lrf::latent_camera(run.scene.views[static_cast<size_t>(i)].camera);
  const lrf::Camera shifted_cam = lrf::shifted_latent_camera(cam, 8, 16);
  auto inside = [](const lrf::Camera& c, const Eigen::Vector3d& p) {
    Eigen::Vector2d px;
    return c.project(p, &px) && px.x() >= 0 && px.y() >= 0 && px.x() < c.width && px.y() < c.height;
  };
  const at::Tensor means = run.field.means.detach().to(at::kDouble).contiguous();
  const auto m = means.accessor<double, 2>();
  std::vector<int64_t> seen;
  for (int64_t g = 0; g < means.size(0); ++g) {
    const Eigen::Vector3d p(m[g][0], m[g][1], m[g][2]);
    if (inside(cam, p) && inside(shifted_cam, p)) seen.push_back(g);
  }
  ASSERT_GT(seen.size(), run.field.size() / 4);
  lrf::splat::Gaussians both = run.field.clone();
  const at::Tensor rows = torch::tensor(seen, at::kLong);
  for (auto* t : both.parameters()) *t = t->index_select(0, rows);
  const at::Tensor plain = lrf::splat::render_field(both, cam, run.render).image;
  const at::Tensor shifted = lrf::splat::render_field(both, shifted_cam, run.render).image;
  const int64_t h = plain.size(1), w = plain.size(2);
  const at::Tensor moved = shifted.narrow(1, 2, h - 2).narrow(2, 1, w - 1);
  const at::Tensor source = plain.narrow(1, 0, h - 2).narrow(2, 0, w - 1);
  // The same splats over the same pixels in the same order: equal but for the rounding of the projected
  // positions (measured: 3e-7, on fields fitted to either encoder's latents).
  EXPECT_LT((moved - source).abs().max().item<double>(), 1e-5);
  EXPECT_GT((shifted - plain).abs().mean().item<double>(), 1e-2);  // the scene is not flat
}

// With --jitter every step sees its view through a camera shifted by a fraction of a latent cell and the
// image moved with it. The held-out views improve much as without it (measured: L1 0.1109 -> 0.1007 after
// 60 steps, against 0.0972 unshifted); a resumed run is the uninterrupted one. (This smooth scene forgives
// misregistration: with the shift's sign reversed the same run gives 0.1022. The sign is pinned by the two
// tests above.)
TEST_F(RefineRun, JitteredRunLowersTheHeldOutLossAndResumesExactly) {
  const double before = held_out_l1(*dir_ / "field");
  auto o = options("jittered", 60);
  o.jitter = 7;
  lrf::refine_latent_field(o);
  const double after = held_out_l1(*dir_ / "jittered");
  std::printf("held-out mean L1 with jitter %.4f -> %.4f\n", before, after);
  EXPECT_LT(after, 0.95 * before) << "before " << before << " after " << after;
  EXPECT_EQ(lrf::read_json_file(*dir_ / "jittered/config.json")["refine"]["options"]["jitter"], 7);
  auto part = options("jittered_part", 30);
  part.jitter = 7;
  part.crop = 48;
  auto whole = part;
  whole.out = *dir_ / "jittered_whole";
  lrf::refine_latent_field(whole);
  refine_interrupted_at(part, 15);
  expect_same_field("jittered_whole", "jittered_part");
}

// Windows instead of whole views, interrupted and resumed: the same field as one uninterrupted run.
TEST_F(RefineRun, ResumedWindowedRunEqualsUninterruptedRun) {
  auto whole = options("uninterrupted", 40);
  whole.crop = 48;
  lrf::refine_latent_field(whole);
  auto part = options("interrupted", 40);
  part.crop = 48;
  refine_interrupted_at(part, 20);
  expect_same_field("uninterrupted", "interrupted");
  // Another option on resume is refused.
  part.resume = true;
  part.lr_scale = 2;
  EXPECT_NE(lrf::test::error_of([&] { lrf::refine_latent_field(part); }).find("other options"), std::string::npos);
}

// With --decoder-lr the decoder adapts with the field: it is saved in OUT, becomes the run's decoder (eval
// uses it), differs from the stock decoder, and a resumed run ends with the same field and decoder.
TEST_F(RefineRun, AdaptedDecoderIsSavedUsedAndResumedExactly) {
  auto whole = options("adapt_whole", 12);
  whole.decoder_lr = 1e-4;
  whole.crop = 48;
  lrf::refine_latent_field(whole);
  auto part = whole;
  part.out = *dir_ / "adapt_part";
  refine_interrupted_at(part, 6);
  const std::string dec_whole = *dir_ / "adapt_whole/decoder.safetensors";
  const std::string dec_part = *dir_ / "adapt_part/decoder.safetensors";
  ASSERT_TRUE(fs::exists(dec_whole));
  auto a = lrf::load_autoencoder(taef2(), "", dec_whole), b = lrf::load_autoencoder(taef2(), "", dec_part);
  auto stock = lrf::load_autoencoder(taef2());
  auto da = a->decoder_state(), db = b->decoder_state(), ds = stock->decoder_state();
  int changed = 0;
  for (const auto& item : da) {
    EXPECT_TRUE(torch::equal(item.value(), db[item.key()])) << item.key();
    changed += !torch::equal(item.value(), ds[item.key()]);
  }
  EXPECT_GT(changed, 0);
  expect_same_field("adapt_whole", "adapt_part");
  lrf::LatentRun run = lrf::open_latent_run(*dir_ / "adapt_whole");
  EXPECT_EQ(fs::weakly_canonical(run.decoder), fs::weakly_canonical(dec_whole));
  EXPECT_EQ(lrf::evaluate_latent_run(*dir_ / "adapt_whole", {})["decoder"], run.decoder);
}

// --decoder-scale 2: only the decoder's layers at up to twice the latent resolution adapt (TAEF2: its
// first convolution and blocks, the first upsampling's convolution and blocks); the finer ones keep the
// stock weights while the field is still trained through them.
TEST_F(RefineRun, DecoderAdaptedUpToAScaleKeepsItsFinerLayers) {
  auto o = options("adapt_coarse", 6);
  o.decoder_lr = 1e-4;
  o.decoder_scale = 2;
  o.crop = 48;
  lrf::refine_latent_field(o);
  auto adapted = lrf::load_autoencoder(taef2(), "", *dir_ / "adapt_coarse/decoder.safetensors");
  auto stock = lrf::load_autoencoder(taef2());
  auto da = adapted->decoder_state(), ds = stock->decoder_state();
  int coarse_changed = 0, fine = 0;
  for (const auto& item : da) {
    const int scale = stock->decoder_parameter_scale(item.key());
    if (scale <= 2) {
      coarse_changed += !torch::equal(item.value(), ds[item.key()]);
    } else {
      ++fine;
      EXPECT_TRUE(torch::equal(item.value(), ds[item.key()])) << item.key() << " at scale " << scale;
    }
  }
  EXPECT_GT(coarse_changed, 10);
  EXPECT_GT(fine, 10);
  // The layers' scales: the first convolution at the latent's, then after each upsampling twice that.
  EXPECT_EQ(stock->decoder_parameter_scale("1.weight"), 1);
  EXPECT_EQ(stock->decoder_parameter_scale("7.weight"), 2);
  EXPECT_EQ(stock->decoder_parameter_scale("13.conv.0.weight"), 4);
  EXPECT_EQ(stock->decoder_parameter_scale("19.bias"), 8);
  EXPECT_EQ(stock->decoder_parameters(8).size(), stock->decoder_parameters().size());
  EXPECT_LT(stock->decoder_parameters(2).size(), stock->decoder_parameters(4).size());
  EXPECT_LT(stock->decoder_parameters(4).size(), stock->decoder_parameters(8).size());
  lrf::KLConfig cfg;
  cfg.ch = 32;
  lrf::KLAutoencoder kl(cfg);
  EXPECT_EQ(kl.decoder_parameter_scale("decoder.up.3.block.0.conv1.weight"), 1);
  EXPECT_EQ(kl.decoder_parameter_scale("decoder.up.3.upsample.conv.weight"), 2);
  EXPECT_EQ(kl.decoder_parameter_scale("decoder.up.0.block.2.conv2.bias"), 8);
  EXPECT_EQ(kl.decoder_parameter_scale("decoder.conv_out.weight"), 8);
  EXPECT_EQ(kl.decoder_parameter_scale("post_quant_conv.weight"), 1);
  o.decoder_scale = 3;
  o.out = *dir_ / "adapt_bad";
  EXPECT_NE(lrf::test::error_of([&] { lrf::refine_latent_field(o); }).find("power of two"), std::string::npos);
}

// --lr-final decays the decoder's rate with the field's. Adam moves each weight by about its rate per
// step, so a decay to 1 % over the whole run (a mean factor near 0.2) moves the decoder well under 0.7 of
// what the constant rate does.
TEST_F(RefineRun, DecoderRateDecaysWithTheFields) {
  auto constant = options("decay_constant", 8);
  constant.decoder_lr = 1e-4;
  constant.crop = 48;
  lrf::refine_latent_field(constant);
  auto decayed = constant;
  decayed.out = *dir_ / "decay_whole";
  decayed.lr_final = 0.01;
  lrf::refine_latent_field(decayed);
  auto stock = lrf::load_autoencoder(taef2());
  auto moved = [&](const std::string& out) {
    auto ae = lrf::load_autoencoder(taef2(), "", *dir_ / (out + "/decoder.safetensors"));
    double sum = 0;
    auto d = ae->decoder_state(), s = stock->decoder_state();
    for (const auto& item : d) sum += (item.value() - s[item.key()]).abs().sum().item<double>();
    return sum;
  };
  const double m_constant = moved("decay_constant"), m_decayed = moved("decay_whole");
  EXPECT_GT(m_decayed, 0);
  EXPECT_LT(m_decayed, 0.7 * m_constant);
}

// --densify-until: the field keeps growing where the image loss's screen-space gradient is large, and
// such a run resumes exactly (the densification statistics travel in the checkpoint). Without it the
// field keeps Stage II's Gaussians (the other tests' runs).
TEST_F(RefineRun, DensifiedRunGrowsAndResumesExactly) {
  const int64_t before = lrf::open_latent_run(*dir_ / "field").field.size();
  auto whole = options("dens_whole", 12);
  whole.densify_until = 10;
  whole.densify_interval = 4;  // densifies at step 8, after the resume point
  whole.densify_grad = 1e-5;
  auto r = lrf::refine_latent_field(whole);
  EXPECT_GT(r.gaussians, before);
  auto part = whole;
  part.out = *dir_ / "dens_part";
  refine_interrupted_at(part, 6);
  expect_same_field("dens_whole", "dens_part");
}

// Mean |rendered - encoded| over the training views, in the field's normalised latent space.
double train_latent_gap(const std::string& run_dir) {
  lrf::LatentRun run = lrf::open_latent_run(run_dir);
  auto ae = lrf::load_autoencoder(run.autoencoder, run.encoder);
  torch::NoGradGuard no_grad;
  double sum = 0;
  for (int i : run.scene.train_indices) {
    const at::Tensor encoded = run.range.normalize(ae->encode(lrf::image_to_batch(run.scene.load_image(i))))[0];
    sum += (lrf::render_latent(run, i) - encoded).abs().mean().item<double>();
  }
  return sum / double(run.scene.train_indices.size());
}

// --lambda-latent holds the rendered latents near the encoded training views while the image loss pulls
// them towards whatever decodes best: the same refinement with the anchor ends closer to the encoder's
// latents than without it, and closer than the field it started from. Measured (30 steps, weight 10): gap
// 0.0864 before, 0.0867 refined freely, 0.0835 anchored; the test asks for 2 % below the free run (a
// broken anchor gives the free run's field bit for bit).
TEST_F(RefineRun, LatentAnchorKeepsTheFieldNearTheEncodedViews) {
  auto free = options("anchor_off", 30);
  lrf::refine_latent_field(free);
  auto held = options("anchor_on", 30);
  held.lambda_latent = 10;
  held.cache_dir = *dir_ / "anchor_cache";  // the encoded anchors go to the cache the caller names
  lrf::refine_latent_field(held);
  EXPECT_TRUE(fs::exists(held.cache_dir) && !fs::is_empty(held.cache_dir));
  const double before = train_latent_gap(*dir_ / "field");
  const double off = train_latent_gap(*dir_ / "anchor_off"), on = train_latent_gap(*dir_ / "anchor_on");
  std::printf("latent gap to the encoded training views: field %.4f, refined %.4f, refined with anchor %.4f\n",
              before, off, on);
  EXPECT_LT(on, 0.98 * off);
  EXPECT_LT(on, before);
}

// --geometry-lr-scale 0: the means, scales, rotations and opacities stay exactly as Stage II left them
// while the latent features still move (a broken freeze moves the means at the first Adam step).
TEST_F(RefineRun, FrozenGeometryMovesOnlyTheFeatures) {
  auto o = options("frozen", 10);
  o.geometry_lr_scale = 0;
  lrf::refine_latent_field(o);
  auto before = lrf::splat::read_ply(*dir_ / "field/point_cloud.ply", 32);
  auto after = lrf::splat::read_ply(*dir_ / "frozen/point_cloud.ply", 32);
  ASSERT_EQ(before.size(), after.size());
  // The trainer stores its Gaussians in spatial order; put the source field in the same order.
  before.permute_rows(lrf::splat::spatial_order(before.means));
  EXPECT_TRUE(torch::equal(before.means, after.means));
  EXPECT_TRUE(torch::equal(before.log_scales, after.log_scales));
  EXPECT_TRUE(torch::equal(before.quats, after.quats));
  EXPECT_TRUE(torch::equal(before.opacity_logits, after.opacity_logits));
  EXPECT_FALSE(torch::equal(before.sh, after.sh));
  const auto config = lrf::read_json_file(*dir_ / "frozen/config.json");
  EXPECT_EQ(config["refine"]["options"]["geometry_lr_scale"].get<double>(), 0.0);
}

TEST_F(RefineRun, BadInputIsReported) {
  auto same = options("x", 5);
  same.out = same.run;
  EXPECT_NE(lrf::test::error_of([&] { lrf::refine_latent_field(same); }).find("another output folder"),
            std::string::npos);
  auto odd = options("y", 5);
  odd.crop = 12;
  EXPECT_NE(lrf::test::error_of([&] { lrf::refine_latent_field(odd); }).find("multiple of 8"), std::string::npos);
  auto missing = options("z", 5);
  missing.run = *dir_ / "no_such_run";
  EXPECT_NE(lrf::test::error_of([&] { lrf::refine_latent_field(missing); }).find("config.json"), std::string::npos);
  auto dens = options("v", 5);
  dens.densify_until = 3;
  dens.densify_interval = 0;
  EXPECT_NE(lrf::test::error_of([&] { lrf::refine_latent_field(dens); }).find("--densify-interval"), std::string::npos);
  auto anchor = options("u", 5);
  anchor.lambda_latent = -1;
  EXPECT_NE(lrf::test::error_of([&] { lrf::refine_latent_field(anchor); }).find("--lambda-latent"), std::string::npos);
  auto anchored_jitter = options("s", 5);  // jitter is on by default: the anchor asks for it off
  anchored_jitter.lambda_latent = 1;
  anchored_jitter.jitter = lrf::RefineOptions{}.jitter;
  EXPECT_NE(lrf::test::error_of([&] { lrf::refine_latent_field(anchored_jitter); }).find("--jitter 0"),
            std::string::npos);
  auto geometry = options("t", 5);
  geometry.geometry_lr_scale = -1;
  EXPECT_NE(lrf::test::error_of([&] { lrf::refine_latent_field(geometry); }).find("--geometry-lr-scale"),
            std::string::npos);
  auto cli = lrf::test::run_lrf("refine " + (*dir_ / "no_such_run") + " -o " + (*dir_ / "w"));
  EXPECT_NE(cli.exit_code, 0);
  EXPECT_NE(cli.output.find("config.json"), std::string::npos) << cli.output;
}

}  // namespace
