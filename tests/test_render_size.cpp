// Render sizes and scales are bounded before any work: `--scale nan` wrote 1x1 images and exited 0,
// `--scale 40` wrote 20160x15120 images, `--width 100000 --height 100000` failed in libtorch after 49 s.
#include <cmath>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "field_helpers.h"
#include "lrf/splat/run/render_size.h"
#include "lrf/splat/run/run_folder.h"
#include "test_helpers.h"

namespace fs = std::filesystem;

namespace {

// The message of the lrf::UsageError `f` throws ("" when none; "other error" for another lrf::Error).
std::string usage_error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const lrf::UsageError& e) {
    return e.what();
  } catch (const lrf::Error&) {
    return "other error";
  }
  return "";
}

TEST(RenderSize, ScalesAndSizesAreBounded) {
  using lrf::splat::check_render_options;
  EXPECT_EQ(usage_error_of([] { check_render_options(1, 0, 0); }), "");
  EXPECT_EQ(usage_error_of([] { check_render_options(0.5, 8192, 8192); }), "");
  for (double bad : {std::nan(""), HUGE_VAL, -HUGE_VAL, 0.0, -2.0}) {
    EXPECT_NE(usage_error_of([&] { check_render_options(bad, 0, 0); }).find("--scale must be a finite positive number"),
              std::string::npos) << bad;
  }
  EXPECT_NE(usage_error_of([] { check_render_options(1, 100000, 100000); }).find("at most 8192 pixels per side"),
            std::string::npos);
  EXPECT_NE(usage_error_of([] { check_render_options(1, 8193, 10); }), "");
  EXPECT_NE(usage_error_of([] { check_render_options(1, -5, 10); }).find("must be positive"), std::string::npos);
  EXPECT_NE(usage_error_of([] { check_render_options(1, 64, 0); }).find("go together"), std::string::npos);

  // A scale is checked against the views' size, naming the largest that fits.
  lrf::Camera fern;
  fern.width = 504;
  fern.height = 378;
  fern.fx = fern.fy = 400;
  EXPECT_EQ(lrf::splat::scaled_camera(fern, 16, 0, 0).width, 8064);
  const std::string msg = usage_error_of([&] { lrf::splat::scaled_camera(fern, 40, 0, 0); });
  EXPECT_NE(msg.find("--scale 40 would render 20160x15120 images"), std::string::npos) << msg;
  EXPECT_NE(msg.find("--scale 16.25 at most"), std::string::npos) << msg;
}

// The CLI refuses them with a usage error (2) before it writes anything.
TEST(RenderSize, CliRefusesBeforeWriting) {
  const std::string field = lrf::test::tiny_field("rgb");  // 64x48 views
  lrf::test::TempDir tmp("render_size");
  for (const std::string bad : {"--scale nan", "--scale inf", "--scale -1", "--scale 200",
                                 "--width 100000 --height 100000", "--width 64"}) {
    auto r = lrf::test::run_lrf("render '" + field + "' " + bad + " -o '" + tmp / "out" + "'");
    EXPECT_EQ(r.exit_code, 2) << bad << "\n" << r.output;
    EXPECT_FALSE(fs::exists(tmp / "out")) << bad;
  }
  auto video = lrf::test::run_lrf("render '" + field + "' --path orbit --frames 2 --scale 1e9 --video '" +
                                  tmp / "v.mp4" + "'");
  EXPECT_EQ(video.exit_code, 2) << video.output;
  auto eval = lrf::test::run_lrf("eval '" + field + "' --scale nan");
  EXPECT_EQ(eval.exit_code, 2) << eval.output;
  // Within the bounds it renders.
  auto ok = lrf::test::run_lrf("-q render '" + field + "' --width 32 --height 24 -o '" + tmp / "ok" + "'");
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
}

}  // namespace
