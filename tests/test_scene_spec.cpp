// Scene arguments with their own resolution (PATH:--images=DIR:--downscale=N): what parses, and that every
// malformed one is refused with a message naming the argument and what is wrong.
#include <filesystem>

#include <gtest/gtest.h>

#include "lrf/core/error.h"
#include "lrf/scene/scene_spec.h"
#include "test_helpers.h"

namespace fs = std::filesystem;
using lrf::test::error_of;

namespace {

TEST(SceneSpec, ParsesPlainPathsAndPerSceneOptions) {
  lrf::SceneSpec s = lrf::parse_scene_spec("../shared/scenes/llff-fern");
  EXPECT_EQ(s.path, "../shared/scenes/llff-fern");
  EXPECT_TRUE(s.resolution.is_default());
  EXPECT_EQ(s.resolution.text(), "");

  s = lrf::parse_scene_spec("../shared/scenes/llff-fern:--images=images_8");
  EXPECT_EQ(s.path, "../shared/scenes/llff-fern");
  EXPECT_EQ(s.resolution.images, "images_8");
  EXPECT_EQ(s.resolution.downscale, 0);
  EXPECT_EQ(s.resolution.text(), "--images=images_8");

  s = lrf::parse_scene_spec("scenes/flower:--downscale=2");
  EXPECT_EQ(s.path, "scenes/flower");
  EXPECT_EQ(s.resolution.images, "");
  EXPECT_EQ(s.resolution.downscale, 2);

  // Both, in either order; the text puts them in one order.
  for (const char* text : {"a/b:--images=images_4:--downscale=3", "a/b:--downscale=3:--images=images_4"}) {
    s = lrf::parse_scene_spec(text);
    EXPECT_EQ(s.path, "a/b") << text;
    EXPECT_EQ(s.resolution.images, "images_4") << text;
    EXPECT_EQ(s.resolution.downscale, 3) << text;
    EXPECT_EQ(s.resolution.text(), "--images=images_4:--downscale=3") << text;
    EXPECT_EQ(s.resolution.json(), (nlohmann::json{{"images", "images_4"}, {"downscale", 3}})) << text;
  }

  // A ':' in a path is part of the path unless an option starts after it.
  s = lrf::parse_scene_spec("/data/run:2024/scene");
  EXPECT_EQ(s.path, "/data/run:2024/scene");
  EXPECT_TRUE(s.resolution.is_default());
  s = lrf::parse_scene_spec("C:/scenes/x:-not-an-option:--downscale=4");
  EXPECT_EQ(s.path, "C:/scenes/x:-not-an-option");
  EXPECT_EQ(s.resolution.downscale, 4);
}

TEST(SceneSpec, RefusesMalformedOptionsNamingTheArgument) {
  const struct {
    const char* text;
    const char* expected;
  } cases[] = {
      {"fern:--size=2", "unknown option '--size=2'"},
      {"fern:--Images=images_8", "unknown option '--Images=images_8'"},
      {"fern:--", "unknown option '--'"},
      {"fern:--downscale", "--downscale needs a value"},
      {"fern:--images", "--images needs a value"},
      {"fern:--downscale=0", "--downscale '0' is not a whole number from 1 to 65536"},
      {"fern:--downscale=-2", "--downscale '-2' is not a whole number"},
      {"fern:--downscale=2x", "--downscale '2x' is not a whole number"},
      {"fern:--downscale=1.5", "--downscale '1.5' is not a whole number"},
      {"fern:--downscale=", "--downscale '' is not a whole number"},
      {"fern:--downscale=99999999999", "--downscale '99999999999' is not a whole number"},
      {"fern:--images=", "--images '' is not the name of an image folder"},
      {"fern:--images=../images", "--images '../images' is not the name of an image folder"},
      {"fern:--images=..", "--images '..' is not the name"},
      {"fern:--downscale=2:--downscale=4", "--downscale is given twice"},
      {"fern:--images=a:--images=b", "--images is given twice"},
      {":--downscale=2", "no scene folder before the options"},
      {"", "no scene folder"},
  };
  for (const auto& c : cases) {
    bool usage = false;
    std::string msg;
    try {
      lrf::parse_scene_spec(c.text);
    } catch (const lrf::UsageError& e) {
      usage = true;
      msg = e.what();
    }
    EXPECT_TRUE(usage) << c.text;  // a command line lrf refuses: exit status 2
    EXPECT_NE(msg.find(std::string("scene '") + c.text + "'"), std::string::npos) << c.text << ": " << msg;
    EXPECT_NE(msg.find(c.expected), std::string::npos) << c.text << ": " << msg;
  }
}

TEST(SceneSpec, ChecksTheSceneAndImageFoldersExist) {
  const std::string scene = lrf::test::synthetic_scene();
  EXPECT_EQ(error_of([&] { lrf::check_scene_spec_folders(lrf::parse_scene_spec(scene), scene); }), "");
  const std::string with_images = scene + ":--images=images";
  EXPECT_EQ(error_of([&] { lrf::check_scene_spec_folders(lrf::parse_scene_spec(with_images), with_images); }), "");

  const std::string missing = scene + "-missing:--downscale=2";
  std::string msg = error_of([&] { lrf::check_scene_spec_folders(lrf::parse_scene_spec(missing), missing); });
  EXPECT_NE(msg.find(scene + "-missing: scene folder not found (from '" + missing + "')"), std::string::npos) << msg;

  const std::string bad_images = scene + ":--images=images_8";
  msg = error_of([&] { lrf::check_scene_spec_folders(lrf::parse_scene_spec(bad_images), bad_images); });
  EXPECT_NE(msg.find((fs::path(scene) / "images_8").string() + ": image folder not found (--images=images_8 of '" +
                     bad_images + "')"),
            std::string::npos)
      << msg;
}

}  // namespace
