// The pipeline's job records (pipeline_jobs.h): every job gets the pipeline's shared settings, its own
// stage's settings, and nothing of another stage's.
#include <gtest/gtest.h>

#include "lrf/pipeline/pipeline_jobs.h"

namespace {

lrf::PipelineOptions options_set_apart() {
  lrf::PipelineOptions o;
  o.autoencoder = "some-autoencoder";
  o.cache_dir = "/cache";
  o.lpips_weights = "lpips.pth";
  o.seed = 17;
  o.max_side = 320;
  o.field_iters = 1234;
  o.eval_train_views = 3;
  o.stage1.steps = 11;
  o.stage1.encoder = "an encoder the pipeline must not start from";
  o.stage3.steps = 22;
  o.stage3.crop = 64;
  o.refine.steps = 33;
  o.detail.views = 5;
  o.rgb_full = true;
  return o;
}

lrf::PipelineScenes two_scenes() {
  lrf::PipelineScenes s;
  s.train = {"/scenes/a"};
  s.eval = {"/scenes/b"};
  s.given["/scenes/a"] = lrf::SceneResolution{};
  s.given["/scenes/b"] = lrf::SceneResolution{};
  return s;
}

TEST(PipelineJobs, EveryJobGetsTheSharedSettingsAndItsOwn) {
  const lrf::PipelineOptions o = options_set_apart();
  const lrf::PipelinePaths paths{"/out", lrf::protocol_suffix(o.eval_train_views)};
  const lrf::PipelineJobs jobs = lrf::pipeline_jobs(o, two_scenes(), paths);

  EXPECT_EQ(jobs.stage1.scenes, std::vector<std::string>{"/scenes/a"});
  EXPECT_TRUE(jobs.stage1.scene_resolutions.empty());  // no scene was given a resolution of its own
  EXPECT_EQ(jobs.stage1.autoencoder, "some-autoencoder");
  EXPECT_TRUE(jobs.stage1.encoder.empty());  // Stage I starts from the autoencoder's own encoder
  EXPECT_EQ(jobs.stage1.out, paths.encoder());
  EXPECT_EQ(jobs.stage1.max_side, 320);
  EXPECT_EQ(jobs.stage1.seed, 17u);
  EXPECT_EQ(jobs.stage1.steps, 11);

  EXPECT_EQ(jobs.stage3.autoencoder, "some-autoencoder");
  EXPECT_EQ(jobs.stage3.seed, 17u);
  EXPECT_EQ(jobs.stage3.steps, 22);
  EXPECT_EQ(jobs.stage3.crop, 64);
  EXPECT_EQ(jobs.stage3.weight_roundtrip, lrf::kRecommendedWeightRoundtrip);

  EXPECT_EQ(jobs.latent_field.autoencoder, "some-autoencoder");
  EXPECT_EQ(jobs.latent_field.cache_dir, "/cache");
  EXPECT_EQ(jobs.latent_field.iters, 1234);
  EXPECT_EQ(jobs.latent_field.seed, 17u);
  EXPECT_EQ(jobs.latent_field.sh_degree, lrf::kDefaultLatentShDegree);

  EXPECT_EQ(jobs.rgb_field.iters, 1234);
  EXPECT_EQ(jobs.rgb_field.seed, 17u);
  EXPECT_EQ(jobs.rgb_field.scene_options.train_views, 3);
  EXPECT_TRUE(jobs.rgb_field.scene_options.crop_to_multiple_of_8);  // the latent fields' views
  ASSERT_EQ(jobs.baselines.size(), 4u);  // rgb/8, rgb/8-mip and, with rgb_full, rgb and rgb-mip
  EXPECT_STREQ(jobs.baselines[3].row, "rgb-mip");

  EXPECT_EQ(jobs.refine.steps, 33);
  EXPECT_EQ(jobs.refine.seed, 17u);
  EXPECT_EQ(jobs.refine.cache_dir, "/cache");

  EXPECT_EQ(jobs.scoring.lpips_weights, "lpips.pth");
  EXPECT_EQ(jobs.scoring.detail.views, 5);
  EXPECT_TRUE(jobs.scoring.decoder.empty());
  EXPECT_EQ(jobs.eval_train_views, 3);
}

TEST(PipelineJobs, NoBaselinesWithoutTheRgbRows) {
  lrf::PipelineOptions o = options_set_apart();
  o.rgb_baseline = false;
  const lrf::PipelineJobs jobs = lrf::pipeline_jobs(o, two_scenes(), {"/out", ""});
  EXPECT_TRUE(jobs.baselines.empty());
  o.rgb_baseline = true;
  o.rgb_full = false;
  EXPECT_EQ(lrf::pipeline_jobs(o, two_scenes(), {"/out", ""}).baselines.size(), 2u);
}

}  // namespace
