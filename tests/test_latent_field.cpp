// Stage II end to end on a synthetic scene with the real TAEF2 weights: latent cache, training, render,
// decode and evaluation, and the bad-input cases (changed autoencoder, corrupt cache).
#include <chrono>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "lrf/autoencoder/autoencoder.h"
#include "lrf/autoencoder/image_tensor.h"
#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/core/run_info.h"
#include "lrf/latent/latent_cache.h"
#include "lrf/latent/latent_field.h"
#include "lrf/latent/latent_run.h"
#include "lrf/latent/latent_train_run.h"
#include "lrf/splat/ply_io.h"
#include "test_helpers.h"

namespace fs = std::filesystem;

namespace {

std::string taef2() { return lrf::test::shared_dir() + "/models/taef2"; }

TEST(LatentCache, SecondCallReadsTheCacheAndACorruptCacheIsRebuilt) {
  lrf::SceneOptions so;
  so.crop_to_multiple_of_8 = true;
  lrf::Scene s = lrf::load_scene(lrf::test::synthetic_scene({6, "64x48", 4, 200}), so);
  auto ae = lrf::load_autoencoder(taef2());
  const std::string id = lrf::autoencoder_identity(taef2(), "");
  lrf::test::TempDir cache("latent_cache");
  auto a = lrf::encode_views_cached(s, {0, 1, 2}, *ae, id, cache.str());
  EXPECT_FALSE(a.hit);
  ASSERT_EQ(a.latents.size(), 3u);
  EXPECT_EQ(a.latents[0].sizes(), (std::vector<int64_t>{ae->latent_channels(), 6, 8}));
  auto b = lrf::encode_views_cached(s, {0, 1, 2}, *ae, id, cache.str());
  EXPECT_TRUE(b.hit);
  EXPECT_TRUE(torch::equal(a.latents[2], b.latents[2]));
  // Another autoencoder identity or view list is another key.
  auto c = lrf::encode_views_cached(s, {0, 1}, *ae, id, cache.str());
  EXPECT_FALSE(c.hit);
  lrf::write_file_atomic(b.path, "corrupt");
  auto d = lrf::encode_views_cached(s, {0, 1, 2}, *ae, id, cache.str());
  EXPECT_FALSE(d.hit);
  EXPECT_TRUE(torch::allclose(d.latents[1], a.latents[1]));
}

// A short latent fit reaches a latent-space PSNR on the held-out views that a broken normalisation,
// cache or camera scaling would miss (measured ~19 dB; a field rendering the wrong view or unnormalised
// targets stays near 10 dB), and the decoded images beat decoding a constant latent by a wide margin.
TEST(LatentField, ShortFitOnSyntheticSceneRendersHeldOutViews) {
  lrf::test::TempDir tmp("latent_fit");
  // A private copy of the weights, so that the test can change them under the trained field.
  fs::create_directories(tmp / "models/taef2");
  for (const char* f : {"taef2_encoder.pth", "taef2_decoder.pth"})
    fs::copy_file(taef2() + "/" + f, tmp / ("models/taef2/" + std::string(f)));
  lrf::LatentTrainOptions o;
  o.scene = lrf::test::synthetic_scene({16, "128x96", 7, 1500});
  o.out = tmp / "field";
  o.autoencoder = tmp / "models/taef2";
  o.iters = 400;
  o.cache_dir = tmp / "cache";
  o.checkpoint_every = 200;
  auto r = lrf::train_latent_field(o);
  EXPECT_EQ(r.steps, 400);
  auto m = lrf::evaluate_latent_run(o.out, {});
  EXPECT_TRUE(m["lpips"].is_null());
  EXPECT_TRUE(m.contains("lpips_reason"));
  EXPECT_GT(m["latent_psnr"].get<double>(), 17.0) << m.dump();
  EXPECT_GT(m["psnr"].get<double>(), 17.0) << m.dump();
  EXPECT_LT(m["psnr"].get<double>(), m["roundtrip_psnr"].get<double>() + 1.0);
  EXPECT_TRUE(fs::exists(tmp / "field/eval/view_000.png"));

  // A fresh copy of the same weights (a new time stamp) keeps the field usable...
  const std::string decoder = tmp / "models/taef2/taef2_decoder.pth";
  fs::last_write_time(decoder, fs::last_write_time(decoder) + std::chrono::hours(1));
  EXPECT_NO_THROW(lrf::open_latent_run(o.out));
  // ...but other weights of the same size under the same name are reported, not silently used.
  {
    std::fstream f(decoder, std::ios::in | std::ios::out | std::ios::binary);
    // The middle of the file is tensor data, so the archive stays readable.
    const auto middle = static_cast<std::streamoff>(fs::file_size(decoder) / 2);
    f.seekg(middle);
    char c = 0;
    f.read(&c, 1);
    f.seekp(middle);
    c = static_cast<char>(c ^ 0x01);
    f.write(&c, 1);
  }
  try {
    lrf::open_latent_run(o.out);
    FAIL() << "expected an error";
  } catch (const lrf::Error& e) {
    EXPECT_NE(std::string(e.what()).find("autoencoder's files changed"), std::string::npos) << e.what();
  }
}

// --rgb-guide: every training target gains the view's image at latent resolution (8x8 means) times the
// weight, the field trains with C + 3 channels, and what it writes is a plain C-channel latent field
// (which eval opens); and the guide changes the fit (a guide dropped before training gives the unguided
// field bit for bit).
TEST(LatentField, RgbGuideChannelsShapeTheFitAndAreDroppedFromTheField) {
  lrf::test::TempDir tmp("latent_guide");
  lrf::SceneOptions so;
  so.crop_to_multiple_of_8 = true;
  const std::string scene_dir = lrf::test::synthetic_scene({8, "64x48", 5, 600});
  lrf::Scene scene = lrf::load_scene(scene_dir, so);
  auto ae = lrf::load_autoencoder(taef2());
  auto encoded = lrf::encode_views_cached(scene, scene.train_indices, *ae, lrf::autoencoder_identity(taef2(), ""),
                                          (tmp / "cache"));
  const int c = ae->latent_channels();
  auto data = lrf::prepare_latent_training(scene, encoded.latents, lrf::LatentInit::latents, 0, 0, {}, 2.0);
  ASSERT_EQ(data.views[1].target.size(0), c + 3);
  EXPECT_EQ(data.init.channels(), c + 3);
  // One latent cell's guide is twice the mean of its 8x8 pixels.
  const at::Tensor image = lrf::image_to_batch(scene.load_image(scene.train_indices[1]))[0];
  const double mean = image.index({1, at::indexing::Slice(8, 16), at::indexing::Slice(16, 24)}).mean().item<double>();
  EXPECT_NEAR(data.views[1].target[c + 1][1][2].item<double>(), 2 * mean, 1e-5);

  lrf::LatentTrainOptions o;
  o.scene = scene_dir;
  o.autoencoder = taef2();
  o.iters = 40;
  o.cache_dir = tmp / "cache";
  o.rgb_guide = 1;
  o.out = tmp / "guided";
  lrf::train_latent_field(o);
  auto plain = o;
  plain.rgb_guide = 0;
  plain.out = tmp / "plain";
  lrf::train_latent_field(plain);

  const auto guided = lrf::splat::read_ply(tmp / "guided/point_cloud.ply", c);
  const auto unguided = lrf::splat::read_ply(tmp / "plain/point_cloud.ply", c);
  EXPECT_EQ(guided.channels(), c);
  EXPECT_FALSE(guided.size() == unguided.size() && torch::equal(guided.means, unguided.means));
  EXPECT_EQ(lrf::read_json_file(tmp / "guided/config.json")["rgb_guide"].get<double>(), 1.0);
  EXPECT_GT(lrf::evaluate_latent_run(tmp / "guided", {})["psnr"].get<double>(), 5.0);
  o.rgb_guide = -1;
  o.out = tmp / "bad";
  EXPECT_NE(lrf::test::error_of([&] { lrf::train_latent_field(o); }).find("--rgb-guide"), std::string::npos);
}

}  // namespace
