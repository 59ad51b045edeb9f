// transforms.json and a run's config.json parsed from text: damaged or hostile values are refused with an
// lrf::Error naming the problem (before these parsers were split out, some escaped as nlohmann exceptions
// or undefined float-to-int conversions).
#include <gtest/gtest.h>

#include "lrf/latent/latent_config.h"
#include "lrf/splat/run/field_kind.h"
#include "lrf/scene/transforms_json.h"
#include "lrf/splat/run/run_config.h"
#include "test_helpers.h"

namespace {

using lrf::test::error_of;

std::string transforms_error(const std::string& text) {
  lrf::TransformsImages images;
  images.resolve = [](const std::string& rel) { return rel; };
  images.size = [](const std::string&) { return cv::Size(64, 48); };
  lrf::RawScene raw;
  return error_of([&] { lrf::parse_transforms(text, "t.json", images, &raw, nullptr); });
}

const char* kFrame = R"({"file_path": "images/a.png", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})";

std::string with_frame(const std::string& file_keys, const std::string& frame = kFrame) {
  return "{" + file_keys + (file_keys.empty() ? "" : ", ") + "\"frames\": [" + frame + "]}";
}

nlohmann::json rgb_config() {
  return nlohmann::json::parse(R"({"space": "rgb", "scene": "/s", "images": "images", "downscale": 2,
    "test_every": 8, "sh_degree": 3, "mip": false, "background": [0, 0, 0]})");
}

}  // namespace

TEST(TransformsJson, ParsesAFrameAndRefusesBadValues) {
  EXPECT_EQ(transforms_error(with_frame(R"("fl_x": 50)")), "");
  EXPECT_NE(transforms_error(with_frame(R"("fl_x": 50, "camera_model": 3)")).find("camera_model"), std::string::npos);
  EXPECT_NE(transforms_error(with_frame(R"("fl_x": 50, "w": 1e300, "h": 10)")).find("pixels per side"), std::string::npos);
  EXPECT_NE(transforms_error(with_frame(R"("camera_angle_x": 0)")).find("focal"), std::string::npos);
  EXPECT_NE(transforms_error(with_frame(R"("fl_x": 50, "cx": 1e999)")), "");  // overflows to infinity
  const char* empty_path = R"({"file_path": "./", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})";
  EXPECT_NE(transforms_error(with_frame(R"("fl_x": 50)", empty_path)).find("empty"), std::string::npos);
  EXPECT_NE(transforms_error("[1, 2]").find("frames"), std::string::npos);
  EXPECT_NE(transforms_error(with_frame(R"("fl_x": 50)", "7")).find("file_path"), std::string::npos);
}

TEST(FieldConfig, ParsesWhatTrainWritesAndRefusesBadValues) {
  auto c = lrf::splat::parse_field_config(rgb_config(), "config.json");
  EXPECT_EQ(c.kind, lrf::FieldKind::rgb);
  EXPECT_EQ(c.scene.downscale, 2);
  EXPECT_EQ(c.background.size(), 3u);
  auto bad = [](const char* key, nlohmann::json value) {
    auto j = rgb_config();
    j[key] = value;
    return error_of([&] { lrf::splat::parse_field_config(j, "config.json"); });
  };
  EXPECT_NE(bad("downscale", 1e300).find("\"downscale\" is not an integer"), std::string::npos);
  EXPECT_NE(bad("downscale", 0).find("between 1"), std::string::npos);
  EXPECT_NE(bad("test_every", -1).find("test_every"), std::string::npos);
  EXPECT_NE(bad("sh_degree", 7).find("sh_degree"), std::string::npos);
  EXPECT_NE(bad("background", {1e300}).find("finite"), std::string::npos);
  EXPECT_NE(bad("background", nlohmann::json::array()).find("channels"), std::string::npos);
  EXPECT_NE(bad("space", 1).find("space"), std::string::npos);
  EXPECT_NE(bad("space", "latent-nerf").find("not a Gaussian field"), std::string::npos);
  EXPECT_NE(error_of([] { lrf::field_kind_of_config(nlohmann::json::array(), "config.json"); }).find("object"),
            std::string::npos);
  EXPECT_NE(error_of([] { lrf::field_kind_of_config({{"space", "lat"}}, "config.json"); }).find("unknown space 'lat'"),
            std::string::npos);
  EXPECT_EQ(lrf::field_kind_of_config({{"scene", "s"}}, "config.json"), lrf::FieldKind::rgb);  // before "space" existed
  for (auto k : {lrf::FieldKind::rgb, lrf::FieldKind::latent, lrf::FieldKind::latent_nerf})
    EXPECT_EQ(lrf::field_kind_of_config({{"space", lrf::field_kind_name(k)}}, "c"), k);
}

TEST(FieldConfig, LatentConfigNeedsMatchingChannels) {
  auto j = rgb_config();
  j["space"] = "latent";
  j["sh_degree"] = 0;
  j["autoencoder"] = "taef2";
  j["autoencoder_identity"] = "x";
  j["latent_range"] = {{"min", {0, 0}}, {"max", {1, 1}}};
  j["background"] = {0, 0};
  j["resolution"] = {64, 48};
  auto l = lrf::parse_latent_config(j, "config.json");
  EXPECT_EQ(l.range.channels(), 2);
  EXPECT_EQ(l.resolution, (std::vector<int>{64, 48}));
  j["background"] = {0, 0, 0};
  EXPECT_NE(error_of([&] { lrf::parse_latent_config(j, "config.json"); }).find("channels"), std::string::npos);
  j["background"] = {0, 0};
  j["resolution"] = "64x48";
  EXPECT_NE(error_of([&] { lrf::parse_latent_config(j, "config.json"); }).find("resolution"), std::string::npos);
  j["resolution"] = {64, 48};
  j["space"] = "rgb";
  EXPECT_NE(error_of([&] { lrf::parse_latent_config(j, "config.json"); }).find("not a latent field"), std::string::npos);
}
